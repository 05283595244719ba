#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>

#include "commands.hpp"
#include "options.hpp"
#include "tsdf_mcl/error.hpp"
#include "tsdf_mcl/simulator.hpp"

namespace tsdf_mcl::cli {

int run_simulate(int argc, char** argv) {
  Options o("simulate",
            "tsdf-mcl simulate --scene office|MESH --lidar vlp16|os0-64|BEAMTABLE [--route mapping|test] [--seed N]\n"
            "                         [--duration S | --length M] [--rate HZ] [--speed MPS] [--sensor-height M]\n"
            "                         [--range-noise M] [--dropout P] [--odom-noise F] [--obstacles N]\n"
            "                         [--motion-distortion] -o DIR",
            {
                {"scene", "office|MESH", "office", "the built-in office, or a mesh file (STL/PLY/OBJ, metres, z up)"},
                {"scene-seed", "N", "1", "furniture layout of the built-in office"},
                {"ground-plane", "Z|none", "none",
                 "add a ground slab with its top at height Z under the mesh, for meshes without a floor (avz: 0)"},
                {"lidar", "vlp16|os0-64|FILE", "vlp16", "LiDAR model, or a beam table file (see docs/simulator.md)"},
                {"rate", "HZ", "", "sweeps per second [default: vlp16 20 (5-20), os0-64 10 (10 or 20), table's rate]"},
                {"route", "mapping|test", "test",
                 "mapping: covers the whole floor (to build a map); test: a route over a ramp, chosen by the seed"},
                {"seed", "N", "1", "route, obstacles and noise; each seed gives another test route"},
                {"duration", "S", "", "stop after S simulated seconds [default: test 60 m, mapping the whole route]"},
                {"length", "M", "", "stop after M metres driven [default: test 60, mapping the whole route]"},
                {"speed", "MPS", "0.8", "cruise speed; the robot slows in curves"},
                {"sensor-height", "M", "0.5", "sensor origin above the robot base (the floor)"},
                {"range-noise", "M", "0.015", "Gaussian range noise (sigma)"},
                {"dropout", "P", "0", "probability that a return is lost"},
                {"odom-noise", "F", "0.1", "odometry noise relative to the motion per sweep (0: exact odometry)"},
                {"scan-spacing", "M", "",
                 "keep a sweep only after the sensor moved M m or turned 30 deg (0: every sweep) "
                 "[default: mapping 0.5, test 0]"},
                {"obstacles", "N", "0", "unmapped people-sized boxes beside a test route"},
                {"motion-distortion", "", "off",
                 "cast each column from the pose at its firing time (off: the whole sweep from its end pose)"},
                {"output", "DIR", "", "output dataset directory; must not hold scans yet"},
            },
            argc, argv, 2);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  o.expect_positional(0, "options only, e.g. --scene office --lidar vlp16 -o DIR");
  if (!o.has("output")) throw Error("missing -o DIR (the output dataset directory)");

  sim::SimulationOptions s;
  s.scene = o.text("scene");
  s.scene_seed = o.count("scene-seed");
  if (o.text("ground-plane") != "none") s.ground_plane_z = o.number("ground-plane");
  s.lidar = o.text("lidar");
  if (o.has("rate")) {
    s.rate_hz = o.number("rate");
    if (!(s.rate_hz > 0.0)) throw Error("--rate must be positive");
  }
  const std::string route = o.text("route");
  if (route != "mapping" && route != "test")
    throw Error("--route must be mapping or test, not '" + route + "'");
  s.route = route == "mapping" ? sim::RouteKind::mapping : sim::RouteKind::test;
  s.seed = o.count("seed");
  if (o.has("duration") && o.has("length")) throw Error("give --duration or --length, not both");
  if (o.has("duration")) {
    s.duration_s = o.number("duration");
    if (!(s.duration_s > 0.0)) throw Error("--duration must be positive");
  }
  if (o.has("length")) {
    s.length_m = o.number("length");
    if (!(s.length_m > 0.0)) throw Error("--length must be positive");
  }
  s.robot.speed = o.number("speed");
  s.robot.sensor_height = o.number("sensor-height");
  s.noise.range_sigma = o.number("range-noise");
  s.noise.dropout = o.number("dropout");
  s.odometry.relative = o.number("odom-noise");
  s.scan_spacing_m =
      o.has("scan-spacing") ? o.number("scan-spacing") : (s.route == sim::RouteKind::mapping ? 0.5 : 0.0);
  s.obstacles = o.count("obstacles");
  s.motion_distortion = o.flag("motion-distortion");
  const std::string out = o.text("output");

  const bool tty = isatty(fileno(stderr)) != 0;
  auto last_report = std::chrono::steady_clock::now();
  s.progress = [&](std::size_t done, std::size_t total) {
    // Announced once the scene and route are ready, so that bad input ends with a single error line.
    if (done == 1) {
      std::fprintf(stderr, "simulate: scene %s, lidar %s, %s route (seed %llu) -> %s\n", s.scene.c_str(),
                   s.lidar.c_str(), route.c_str(), static_cast<unsigned long long>(s.seed), out.c_str());
    }
    const auto now = std::chrono::steady_clock::now();
    if (done != total && now - last_report < std::chrono::seconds(tty ? 0 : 5)) return;
    last_report = now;
    std::fprintf(stderr, tty ? "\rsimulate: scan %zu/%zu" : "simulate: scan %zu/%zu\n", done, total);
    if (tty && done == total) std::fprintf(stderr, "\n");
  };
  const sim::SimulationSummary r = sim::simulate(s, out);
  std::fprintf(stderr,
               "simulate: %zu scans, %zu points, route %.1f m in %.1f s (traversable floor %.0f m^2); took %.1f s\n",
               r.scans, r.points, r.route_length_m, r.duration_s, r.traversable_area_m2, r.wall_time_s);
  return 0;
}

}  // namespace tsdf_mcl::cli
