#include <unistd.h>

#include <chrono>
#include <memory>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "options.hpp"
#include "progress.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/io/bag_writer.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::cli {

namespace {

// The longest run simulate makes: --duration 1e12 would never end (an hour is 36,000 scans at 10 Hz).
constexpr double kMaxDurationS = 3600.0, kMaxLengthM = 20000.0;

std::string format(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, v);
  return buf;
}

sim::Platform platform_of(const std::string& name) {
  if (name == "ground") return sim::Platform::ground;
  if (name == "handheld") return sim::Platform::handheld;
  if (name == "drone") return sim::Platform::drone;
  throw Error("--platform must be ground, handheld or drone, not '" + name + "'");
}

// "X,Y,YAW" (m, m, deg or with a unit) -> x, y, yaw in rad.
Eigen::Vector3d start_of(const Options& o) {
  const std::vector<std::string> v = o.list("start");
  if (v.size() != 3) throw Error("--start expects X,Y,YAW (m, m, deg), got '" + o.text("start") + "'");
  double xy[2];
  for (int i = 0; i < 2; ++i) {
    char* end = nullptr;
    xy[i] = std::strtod(v[i].c_str(), &end);
    if (v[i].empty() || *end != '\0' || !std::isfinite(xy[i])) {
      throw Error("--start expects X,Y,YAW (m, m, deg), got '" + o.text("start") + "'");
    }
  }
  return {xy[0], xy[1], angle_in_degrees(v[2], "--start's yaw", 2.0 * M_PI)};
}

// "X,Y;X,Y;..." -> points.
std::vector<Eigen::Vector2d> waypoints_of(const std::string& text) {
  std::vector<Eigen::Vector2d> points;
  std::stringstream items(text);
  for (std::string item; std::getline(items, item, ';');) {
    double x = 0.0, y = 0.0;
    char comma = 0;
    std::istringstream in(item);
    if (!(in >> x >> comma >> y) || comma != ',' || !(in >> std::ws).eof() || !std::isfinite(x) || !std::isfinite(y)) {
      throw Error("--waypoints expects X,Y;X,Y;... (m), got '" + item + "'");
    }
    points.emplace_back(x, y);
  }
  if (points.empty()) throw Error("--waypoints expects X,Y;X,Y;... (m), got nothing");
  return points;
}

// "X0,Y0,X1,Y1;..." -> rectangles (min, max).
std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> areas_of(const std::string& text) {
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> areas;
  std::stringstream items(text);
  for (std::string item; std::getline(items, item, ';');) {
    double v[4] = {0, 0, 0, 0};
    char comma[3] = {0, 0, 0};
    std::istringstream in(item);
    if (!(in >> v[0] >> comma[0] >> v[1] >> comma[1] >> v[2] >> comma[2] >> v[3]) || comma[0] != ',' ||
        comma[1] != ',' || comma[2] != ',' || !(in >> std::ws).eof()) {
      throw Error("--skip_areas expects X0,Y0,X1,Y1;... (m), got '" + item + "'");
    }
    areas.emplace_back(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]));
  }
  if (areas.empty()) throw Error("--skip_areas expects X0,Y0,X1,Y1;... (m), got nothing");
  return areas;
}

// simulate's options: the scene, the sensor and its carrier, the route and how long, noise, the output.
std::vector<OptionSpec> simulate_options() {
  return with_verbosity_options({
      {"scene", "office|symmetric|warehouse|two-storey|town|MESH", "office",
       "a built-in scene (docs/simulator.md: a 50 x 20 m office; two identical wings and one landmark; "
       "a 40 x 25 m warehouse with pallet racks; the office on two storeys of one plan joined by a staircase; an "
       "open-air town of streets between buildings), or a mesh file (STL/PLY/OBJ, metres, z up)"},
      {"scene_seed", "N", "1", "furniture of the built-in scenes (the warehouse: pallets; the town: its layout)"},
      {"scene_size", "M", "", "the town's extent, M x M metres (80-400) [default: 120]"},
      {"open_air", "", "off",
       "a mesh of streets in the open: the robot drives the largest connected region (off: the most enclosed)"},
      {"ground_plane", "Z|none", "none",
       "add a ground slab with its top at height Z under the mesh, for meshes without a floor (avz: 0)"},
      {"lidar", "vlp16|os0-64|FILE", "vlp16", "LiDAR model, or a beam table file (see docs/simulator.md)"},
      {"rate", "HZ", "", "sweeps per second [default: vlp16 20 (5-20), os0-64 10 (10 or 20), table's rate]"},
      {"route", "mapping|test", "test",
       "mapping: covers the whole floor (to build a map); test: a route over a ramp, chosen by the seed"},
      {"seed", "N", "1", "route, obstacles and noise; each seed gives another test route"},
      {"start", "X,Y,YAW", "",
       "test route: start at X,Y (m) facing YAW (degrees, or e.g. 1.57rad; 0 = +x) instead of where the "
       "seed says"},
      {"waypoints", "X,Y;X,Y;...", "",
       "test route: drive through these points (m) in order and stop at the last one (quote the ';')"},
      {"storey", "K", "0",
       "multi-storey scenes: the storey a test route runs on (0 the lowest); a mapping route covers every "
       "storey"},
      {"skip_areas", "X0,Y0,X1,Y1;...", "",
       "mapping route: never enter these rectangles (m), e.g. rooms the mapping run skipped (quote the ';')"},
      {"platform", "ground|handheld|drone", "ground",
       "what carries the sensor: a ground robot, a walking person (sensor 1.5 m high, gait sway), a drone "
       "(1.0-2.5 m high, tilting with its acceleration, yaw off the path at times)"},
      {"sensor_tilt", "DEG", "0", "mounting tilt of the LiDAR about its y axis; positive: x axis towards the floor"},
      {"duration", "S", "", "stop after S simulated seconds [default: test 60 m, mapping the whole route]"},
      {"length", "M", "", "stop after M metres driven [default: test 60, mapping the whole route]"},
      {"speed", "MPS", "", "cruise speed; slower in curves [default: ground 0.8, handheld 1.2, drone 1.5]"},
      {"sensor_height", "M", "",
       "sensor origin above the floor [default: ground 0.5, handheld 1.5; the drone's height varies]"},
      {"range_noise", "M", "0.015", "Gaussian range noise (sigma)"},
      {"dropout", "P", "0", "probability that a return is lost"},
      {"odom_noise", "F", "0.1", "odometry noise relative to the motion per sweep (0: exact odometry)"},
      {"scan_spacing", "M", "",
       "keep a sweep only after the sensor moved M m or turned 30 deg (0: every sweep) "
       "[default: mapping 0.5, test 0]"},
      {"obstacles", "N", "0", "unmapped people-sized boxes beside a test route"},
      {"walkers", "N", "0", "unmapped people walking about a test run, giving way to the robot"},
      {"motion_distortion", "", "off",
       "cast each column from the pose at its firing time (off: the whole sweep from its end pose)"},
      {"output", "DIR", "", "output dataset directory; must not hold scans yet"},
      {"bag", "FILE", "",
       "also write the run as a bag: FILE.bag ROS 1, FILE.mcap or FILE.db3 one rosbag2 storage file (MCAP, SQLite3), "
       "any other name a rosbag2 folder (metadata.yaml, NAME_0.mcap); /points (frame lidar), /tf odom -> base_link, "
       "/tf_static base_link -> lidar, /odom, /ground_truth (map -> base_link); docs/bags.md"},
  });
}

// How long the run goes: --duration or --length, each bounded (kMaxDurationS, kMaxLengthM).
void read_run_extent(const Options& o, sim::SimulationOptions& s) {
  if (o.has("duration") && o.has("length")) throw Error("give --duration or --length, not both");
  if (o.has("duration")) {
    s.duration_s = o.number("duration");
    if (!(s.duration_s > 0.0 && s.duration_s <= kMaxDurationS)) {
      throw Error("--duration must be in (0, " + format("%g", kMaxDurationS) + "] s, got " + o.text("duration"));
    }
  }
  if (o.has("length")) {
    s.length_m = o.number("length");
    if (!(s.length_m > 0.0 && s.length_m <= kMaxLengthM)) {
      throw Error("--length must be in (0, " + format("%g", kMaxLengthM) + "] m, got " + o.text("length"));
    }
  }
}

// The simulation's options from the command line, checked in the order the options are listed.
sim::SimulationOptions simulation_options(const Options& o) {
  sim::SimulationOptions s;
  s.scene = o.text("scene");
  s.scene_seed = o.count("scene_seed");
  if (o.has("scene_size")) {
    s.scene_size_m = o.number("scene_size");
    if (s.scene != "town") throw Error("--scene_size applies to --scene town only");
    if (!(s.scene_size_m >= 80.0 && s.scene_size_m <= 400.0))
      throw Error("--scene_size must be in [80, 400] m, got " + o.text("scene_size"));
  }
  s.open_air = o.flag("open_air");
  if (o.text("ground_plane") != "none") s.ground_plane_z = o.number("ground_plane");
  s.lidar = o.text("lidar");
  if (o.has("rate")) {
    s.rate_hz = o.number("rate");
    if (!(s.rate_hz > 0.0)) throw Error("--rate must be positive");
  }
  const std::string route = o.text("route");
  if (route != "mapping" && route != "test") throw Error("--route must be mapping or test, not '" + route + "'");
  s.route = route == "mapping" ? sim::RouteKind::mapping : sim::RouteKind::test;
  s.seed = o.count("seed");
  read_run_extent(o, s);
  s.platform = platform_of(o.text("platform"));
  s.robot = sim::RobotModel::of(s.platform);
  if (o.has("speed")) s.robot.speed = o.number("speed");
  if (o.has("sensor_height")) {
    if (s.platform == sim::Platform::drone)
      throw Error("--sensor_height does not apply to the drone (it flies 1.0-2.5 m high)");
    s.robot.sensor_height = o.number("sensor_height");
  }
  s.sensor_tilt_deg = o.number("sensor_tilt");
  if (o.has("start")) s.start = start_of(o);
  if (o.has("waypoints")) s.waypoints = waypoints_of(o.text("waypoints"));
  s.storey = o.count("storey");
  if (o.has("storey") && s.route == sim::RouteKind::mapping) {
    throw Error("--storey picks a test route's storey; a mapping route covers every storey");
  }
  if (o.has("skip_areas")) s.skip_areas = areas_of(o.text("skip_areas"));
  s.noise.range_sigma = o.number("range_noise");
  s.noise.dropout = o.number("dropout");
  s.odometry.relative = o.number("odom_noise");
  s.scan_spacing_m =
      o.has("scan_spacing") ? o.number("scan_spacing") : (s.route == sim::RouteKind::mapping ? 0.5 : 0.0);
  s.obstacles = o.count("obstacles");
  s.walkers = o.count("walkers");
  s.motion_distortion = o.flag("motion_distortion");
  return s;
}

// --bag: the run written as a bag too, beside the run and scan by scan; it appears under its name only once the run
// completes.
std::unique_ptr<BagWriter> open_bag(const Options& o, sim::SimulationOptions& s) {
  const auto bag_option = o.maybe("bag");
  if (!bag_option) return nullptr;
  // "run/" names the folder run.
  const std::filesystem::path bag_file = std::filesystem::path(*bag_option).filename().empty()
                                             ? std::filesystem::path(*bag_option).parent_path()
                                             : std::filesystem::path(*bag_option);
  check_output_file(bag_file, "bag", input_paths(o, {"scene", "lidar"}));
  auto bag = std::make_unique<BagWriter>(bag_file);
  s.on_scan = [writer = bag.get()](const sim::SimulatedScan& scan) {
    if (writer->scans() == 0) writer->set_base_T_sensor(scan.base_T_sensor);
    writer->add_scan(scan.time, *scan.cloud, scan.rings, scan.world_T_sensor, scan.odom_T_sensor);
  };
  return bag;
}

// What runs: the scene, the LiDAR on its platform, the route, the seed and the output folder.
std::string run_line(const Options& o, const sim::SimulationOptions& s) {
  char line[512];
  std::snprintf(line, sizeof(line), "scene %s, lidar %s on %s, %s route (seed %llu) -> %s", s.scene.c_str(),
                s.lidar.c_str(), o.text("platform").c_str(), o.text("route").c_str(),
                static_cast<unsigned long long>(s.seed), o.text("output").c_str());
  return line;
}

// The closing lines: counts, the route, the landmark's first sight, the bag.
void report_run(Progress& progress, const sim::SimulationSummary& r, const Options& o, const BagWriter* bag) {
  char line[512];
  std::snprintf(line, sizeof(line),
                "%zu scans, %zu points, route %.1f m in %.1f s (traversable floor %.0f m^2); took %.1f s", r.scans,
                r.points, r.route_length_m, r.duration_s, r.traversable_area_m2, r.wall_time_s);
  progress.summary(line);
  if (r.landmark_first_seen_scan) {
    progress.note("the landmark is first in view in scan " + std::to_string(*r.landmark_first_seen_scan) +
                  " (landmark_points.txt)");
  } else if (r.has_landmark) {
    progress.note("the landmark is in view in no scan");
  }
  if (bag) {
    progress.summary("wrote " + o.text("bag") + " (" + std::to_string(bag->scans()) +
                     " scans on /points; tf odom -> base_link -> lidar; /ground_truth)");
  }
}

}  // namespace

int run_simulate(int argc, char** argv) {
  Options o("simulate",
            "tsdf-mcl simulate --scene office|symmetric|warehouse|two-storey|town|MESH --lidar vlp16|os0-64|BEAMTABLE\n"
            "                         [--scene_size M] [--open_air] [--route mapping|test] [--seed N] [--storey K]\n"
            "                         [--start X,Y,YAW] [--waypoints X,Y;X,Y;...] [--platform ground|handheld|drone]\n"
            "                         [--sensor_tilt DEG] [--duration S | --length M] [--rate HZ] [--speed MPS]\n"
            "                         [--sensor_height M] [--range_noise M] [--dropout P] [--odom_noise F]\n"
            "                         [--obstacles N] [--walkers N] [--motion_distortion]\n"
            "                         [--bag FILE.bag|FILE.mcap|FILE.db3|FOLDER] -o DIR",
            simulate_options(), argc, argv, 2);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  o.expect_positional(0, "options only, e.g. --scene office --lidar vlp16 -o DIR");
  if (!o.has("output")) throw Error("missing -o DIR (the output dataset directory)");

  sim::SimulationOptions s = simulation_options(o);
  const std::unique_ptr<BagWriter> bag = open_bag(o, s);
  Progress progress("simulate", verbosity_of(o), "scans");
  s.progress = [&](std::size_t done, std::size_t total) {
    // Announced once the scene and route are ready, so that bad input ends with a single error line.
    if (done == 1) progress.note(run_line(o, s));
    progress.update(done, total, "");
  };
  const sim::SimulationSummary r = sim::simulate(s, o.text("output"));
  if (bag) bag->close();
  report_run(progress, r, o, bag.get());
  return 0;
}

}  // namespace tsdf_mcl::cli
