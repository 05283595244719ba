#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "sim/random.hpp"
#include "sim/route.hpp"
#include "sim/shapes.hpp"
#include "sim/traversability.hpp"
#include "tsdf_mcl/dataset.hpp"
#include "tsdf_mcl/error.hpp"
#include "tsdf_mcl/simulator.hpp"

namespace tsdf_mcl::sim {

namespace fs = std::filesystem;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::Vector3f;

namespace {

constexpr double kDefaultTestLength = 60.0;  // m, when neither a duration nor a length is given
constexpr double kObstacleSize = 0.5;        // m, footprint of a standing person
constexpr double kObstacleHeight = 1.8;
constexpr double kScanSpacingTurn = 30.0 * M_PI / 180.0;  // a turn that keeps a scan despite --scan-spacing

// Stream keys: one independent random stream per purpose.
enum Stream : std::uint64_t { kObstacleStream = 10, kOdometryStream = 11, kScanNoiseStream = 12 };

void require(bool ok, const std::string& message) {
  if (!ok) throw Error(message);
}

void validate(const SimulationOptions& o) {
  const RobotModel& r = o.robot;
  require(r.speed > 0.0 && r.speed <= 5.0, "speed must be in (0, 5] m/s");
  require(r.sensor_height > 0.0 && r.sensor_height <= 3.0, "sensor height must be in (0, 3] m");
  require(r.radius > 0.0 && r.height > 0.0 && r.wheelbase > 0.0 && r.track > 0.0 && r.max_step >= 0.0 &&
              r.max_turn_rate > 0.0 && r.max_acceleration > 0.0 && r.max_slope_deg > 0.0 && r.max_slope_deg < 60.0,
          "robot dimensions and limits must be positive (slope below 60 deg)");
  require(o.noise.range_sigma >= 0.0 && o.noise.range_sigma <= 1.0, "range noise must be in [0, 1] m");
  require(o.noise.dropout >= 0.0 && o.noise.dropout < 1.0, "dropout must be in [0, 1)");
  const OdometryNoise& n = o.odometry;
  require(n.relative >= 0.0 && n.rotation_per_meter >= 0.0 && n.translation_floor >= 0.0 && n.rotation_floor >= 0.0,
          "odometry noise must not be negative");
  require(o.duration_s >= 0.0 && o.length_m >= 0.0, "duration and length must not be negative");
  require(o.duration_s == 0.0 || o.length_m == 0.0, "give a duration or a length, not both");
  require(o.scan_spacing_m >= 0.0, "scan spacing must not be negative");
  require(o.obstacles == 0 || o.route == RouteKind::test,
          "obstacles are unmapped objects: they belong in test runs, not in the mapping run");
  require(o.obstacles <= 1000, "at most 1000 obstacles");
  require(!std::isinf(o.ground_plane_z), "ground plane height must be finite");
}

TriangleMesh load_scene(const SimulationOptions& o, std::string& description) {
  TriangleMesh mesh;
  if (o.scene == "office") {
    mesh = office_scene(o.scene_seed);
    description = "built-in office (scene seed " + std::to_string(o.scene_seed) + ")";
  } else {
    if (!fs::is_regular_file(o.scene)) {
      throw Error("scene '" + o.scene + "' is neither 'office' nor an existing mesh file");
    }
    mesh = load_mesh(o.scene);
    if (mesh.triangles.empty()) throw Error("mesh " + o.scene + " has no triangles");
    description = o.scene;
  }
  if (!std::isnan(o.ground_plane_z)) {
    const Vector3f lo = mesh.min_corner(), hi = mesh.max_corner();
    const auto z = static_cast<float>(o.ground_plane_z);
    add_box(mesh, Vector3f(lo.x() - 0.5f, lo.y() - 0.5f, z - 0.1f), Vector3f(hi.x() + 0.5f, hi.y() + 0.5f, z));
  }
  return mesh;
}

struct Obstacle {
  Vector3f min, max;
};

// People-sized boxes beside the route: on level floor, clear of walls and furniture, never in the robot's way.
std::vector<Obstacle> place_obstacles(const TraversabilityGrid& grid, const Route& route, const RobotModel& robot,
                                      std::size_t count, Rng& rng) {
  std::vector<Obstacle> placed;
  const double half = kObstacleSize / 2;
  const double keep_off_route = robot.radius + half * M_SQRT2 + 0.1;
  const auto& samples = route.samples();
  for (std::size_t k = 0; k < count; ++k) {
    bool done = false;
    for (int attempt = 0; attempt < 2000 && !done; ++attempt) {
      const Route::Sample& s = samples[rng.below(samples.size())];
      const Vector2d p = s.world_T_base.translation().head<2>();
      const Vector2d forward = s.world_T_base.linear().col(0).head<2>().normalized();
      const Vector2d left(-forward.y(), forward.x());
      const double side = rng.chance(0.5) ? 1.0 : -1.0;
      const Vector2d c = p + side * rng.uniform(keep_off_route, 2.5) * left + rng.uniform(-1.0, 1.0) * forward;
      // Every cell under the footprint must be passable floor at one height.
      const int ci = grid.index_of(c);
      if (ci < 0 || std::isnan(grid.floor(ci))) continue;
      const float floor = grid.floor(ci);
      bool ok = true;
      for (double dx = -half; dx <= half + 1e-9 && ok; dx += grid.cell() / 2) {
        for (double dy = -half; dy <= half + 1e-9 && ok; dy += grid.cell() / 2) {
          const int i = grid.index_of(c + Vector2d(dx, dy));
          ok = i >= 0 && grid.passable(i) && std::abs(grid.floor(i) - floor) < 0.02f;
        }
      }
      for (const Route::Sample& t : samples) {
        if (!ok) break;
        ok = (t.world_T_base.translation().head<2>() - c).norm() >= keep_off_route;
      }
      for (const Obstacle& o : placed) {
        if (!ok) break;
        ok = (o.min.head<2>().cast<double>() + Vector2d(half, half) - c).norm() >= 2 * half + 0.3;
      }
      if (!ok) continue;
      placed.push_back({Vector3f(static_cast<float>(c.x() - half), static_cast<float>(c.y() - half), floor - 0.02f),
                        Vector3f(static_cast<float>(c.x() + half), static_cast<float>(c.y() + half),
                                 floor + static_cast<float>(kObstacleHeight))});
      done = true;
    }
    if (!done) {
      throw Error("could not place obstacle " + std::to_string(k + 1) + " of " + std::to_string(count) +
                  " beside the route; ask for fewer --obstacles");
    }
  }
  return placed;
}

// Wheel odometry: the true base motion between two scans, perturbed in proportion to its size, integrated.
class Odometry {
 public:
  Odometry(const OdometryNoise& noise, std::uint64_t seed) : noise_(noise), rng_(seed) {}

  Pose step(const Pose& world_T_base) {
    if (!last_) {
      last_ = world_T_base;
      return odom_T_base_;
    }
    const Pose motion = last_->inverse() * world_T_base;
    last_ = world_T_base;
    const double t = motion.translation().norm();
    const double a = Eigen::AngleAxisd(motion.linear()).angle();
    const double sigma_t = noise_.relative * (t + noise_.translation_floor);
    const double sigma_r = noise_.relative * (a + noise_.rotation_per_meter * t + noise_.rotation_floor);
    const Vector3d dt(rng_.normal(), rng_.normal(), rng_.normal());
    const Vector3d dr(rng_.normal(), rng_.normal(), rng_.normal());
    Pose noisy = motion;
    noisy.translation() += sigma_t * dt;
    const Vector3d rv = sigma_r * dr;
    if (rv.norm() > 0.0)
      noisy.linear() = motion.linear() * Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
    odom_T_base_ = orthonormalized(odom_T_base_ * noisy);
    return odom_T_base_;
  }

 private:
  OdometryNoise noise_;
  Rng rng_;
  std::optional<Pose> last_;
  Pose odom_T_base_ = Pose::Identity();
};

void check_output_dir(const fs::path& dir) {
  std::error_code ec;
  if (fs::exists(dir / "scans", ec) && !fs::is_empty(dir / "scans", ec)) {
    throw Error("output " + dir.string() + " already holds scans; choose a new directory or remove it");
  }
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) throw Error("cannot create output directory " + dir.string());
  const fs::path probe = dir / ".write-test";
  {
    std::ofstream f(probe);
    if (!f) throw Error("output directory " + dir.string() + " is not writable");
  }
  fs::remove(probe, ec);
}

nlohmann::json pose_json(const Pose& p) {
  const Vector3d rpy = rpy_of(p.linear());
  return {{"x", p.translation().x()}, {"y", p.translation().y()}, {"z", p.translation().z()},
          {"roll", rpy.x()},          {"pitch", rpy.y()},         {"yaw", rpy.z()}};
}

// simulation.json: every parameter, the scene, the route and the counts, to reproduce or interpret a run.
void write_description(const fs::path& file, const SimulationOptions& options, const std::string& scene_description,
                       const TriangleMesh& mesh, const LidarModel& lidar, const RobotModel& robot, const Route& route,
                       const std::vector<Obstacle>& obstacles, std::size_t sweeps, const SimulationSummary& summary) {
  nlohmann::json j;
  j["scene"] = {{"source", options.scene},
                {"description", scene_description},
                {"scene_seed", options.scene_seed},
                {"ground_plane_z",
                 std::isnan(options.ground_plane_z) ? nlohmann::json() : nlohmann::json(options.ground_plane_z)},
                {"triangles", mesh.triangles.size()},
                {"min", {mesh.min_corner().x(), mesh.min_corner().y(), mesh.min_corner().z()}},
                {"max", {mesh.max_corner().x(), mesh.max_corner().y(), mesh.max_corner().z()}},
                {"traversable_area_m2", summary.traversable_area_m2},
                {"file", "scene.ply"}};
  j["lidar"] = {{"name", lidar.name},
                {"elevations_deg", lidar.elevations_deg},
                {"columns", lidar.columns},
                {"min_range", lidar.min_range},
                {"max_range", lidar.max_range},
                {"rate_hz", lidar.rate_hz},
                {"spin", "clockwise seen from above, column 0 along +x"},
                {"range_sigma", options.noise.range_sigma},
                {"dropout", options.noise.dropout},
                {"motion_distortion", options.motion_distortion}};
  j["robot"] = {{"radius", robot.radius},
                {"height", robot.height},
                {"max_step", robot.max_step},
                {"max_slope_deg", robot.max_slope_deg},
                {"wheelbase", robot.wheelbase},
                {"track", robot.track},
                {"sensor_height", robot.sensor_height},
                {"speed", robot.speed},
                {"max_turn_rate", robot.max_turn_rate},
                {"max_acceleration", robot.max_acceleration}};
  j["odometry"] = {{"relative", options.odometry.relative},
                   {"rotation_per_meter", options.odometry.rotation_per_meter},
                   {"translation_floor", options.odometry.translation_floor},
                   {"rotation_floor", options.odometry.rotation_floor},
                   {"frame", "odom_T_sensor; the odom frame is the base's first pose"}};
  nlohmann::json waypoints = nlohmann::json::array();
  for (const Vector2d& w : route.waypoints()) waypoints.push_back({w.x(), w.y()});
  j["route"] = {{"kind", options.route == RouteKind::mapping ? "mapping" : "test"},
                {"seed", options.seed},
                {"duration_limit_s", options.duration_s},
                {"length_limit_m", options.length_m},
                {"scan_spacing_m", options.scan_spacing_m},
                {"length_m", route.length()},
                {"duration_s", route.duration()},
                {"waypoints", waypoints},
                {"start", pose_json(route.samples().front().world_T_base)}};
  nlohmann::json boxes = nlohmann::json::array();
  for (const Obstacle& o : obstacles) {
    boxes.push_back({{"min", {o.min.x(), o.min.y(), o.min.z()}}, {"max", {o.max.x(), o.max.y(), o.max.z()}}});
  }
  j["obstacles"] = boxes;
  j["counts"] = {{"sweeps", sweeps}, {"scans", summary.scans}, {"points", summary.points}};
  j["files"] = {{"scans", "scans/NNNNNN.bin: float32 x y z intensity, sensor frame"},
                {"times", "times.txt: end of each sweep (s)"},
                {"poses", "poses.txt: world_T_sensor at the end of each sweep, KITTI 3x4"},
                {"odometry", "odom.txt: odom_T_sensor, KITTI 3x4"}};
  std::ofstream out(file);
  out << j.dump(2) << "\n";
  if (!out) throw Error("cannot write " + file.string());
}

}  // namespace

SimulationSummary simulate(const SimulationOptions& options, const fs::path& out_dir) {
  const auto wall_start = std::chrono::steady_clock::now();
  validate(options);
  const LidarModel lidar = LidarModel::from_name(options.lidar, options.rate_hz);
  check_output_dir(out_dir);

  std::string scene_description;
  TriangleMesh mesh = load_scene(options, scene_description);
  const RayCaster static_scene(mesh);
  // The sensor must not poke into what the robot drives under.
  RobotModel robot = options.robot;
  robot.height = std::max(robot.height, robot.sensor_height + 0.1);
  const double min_floor =
      std::isnan(options.ground_plane_z) ? -std::numeric_limits<double>::infinity() : options.ground_plane_z - 0.01;
  const TraversabilityGrid grid(static_scene, mesh, robot, 0.1, min_floor);

  // A test route is planned at least as long as the run; a mapping route covers the floor.
  double stop_length = options.length_m;
  if (options.route == RouteKind::test && options.length_m == 0.0 && options.duration_s == 0.0) {
    stop_length = kDefaultTestLength;
  }
  const double plan_length = options.duration_s > 0.0 ? options.duration_s * robot.speed + 5.0 : stop_length;
  const Route route = plan_route(grid, static_scene, robot, options.route, options.seed, plan_length)
                          .truncated(options.duration_s, stop_length);

  Rng obstacle_rng(mix_key(options.seed, kObstacleStream));
  const std::vector<Obstacle> obstacles = place_obstacles(grid, route, robot, options.obstacles, obstacle_rng);
  for (const Obstacle& o : obstacles) add_box(mesh, o.min, o.max);
  const RayCaster scene(mesh);
  save_mesh_ply(mesh, out_dir / "scene.ply");

  const double period = 1.0 / lidar.rate_hz;
  const auto sweeps = static_cast<std::size_t>(std::floor(route.duration() / period + 1e-9));
  if (sweeps == 0) throw Error("the route takes less than one scan period; ask for a longer duration or length");
  Pose base_T_sensor = Pose::Identity();
  base_T_sensor.translation().z() = robot.sensor_height;

  // Which sweeps become scans, and their poses: sequential, as odometry integrates every sweep.
  struct Sweep {
    std::size_t index;
    double time;
    Pose start, end, odom_T_sensor;
  };
  std::vector<Sweep> kept;
  Odometry odometry(options.odometry, mix_key(options.seed, kOdometryStream));
  for (std::size_t i = 0; i < sweeps; ++i) {
    const double t = static_cast<double>(i + 1) * period;
    const Pose world_T_base = route.base_pose(t);
    const Pose sensor_end = world_T_base * base_T_sensor;
    const Pose odom_T_sensor = odometry.step(world_T_base) * base_T_sensor;
    if (!kept.empty() && options.scan_spacing_m > 0.0) {
      const Pose moved = kept.back().end.inverse() * sensor_end;
      if (moved.translation().norm() < options.scan_spacing_m &&
          Eigen::AngleAxisd(moved.linear()).angle() < kScanSpacingTurn) {
        continue;
      }
    }
    const Pose sensor_start = options.motion_distortion ? route.base_pose(t - period) * base_T_sensor : sensor_end;
    kept.push_back({i, t, sensor_start, sensor_end, odom_T_sensor});
  }

  // Scans in batches, one scan per thread: a fork and join per batch rather than per scan keeps both cores
  // busy even when other processes compete for them.
  DatasetWriter writer(out_dir);
  const std::uint64_t noise_seed = mix_key(options.seed, kScanNoiseStream);
  SimulationSummary summary;
  constexpr std::size_t kBatch = 32;
  std::vector<PointCloud> clouds(kBatch);
  for (std::size_t first = 0; first < kept.size(); first += kBatch) {
    const auto count = static_cast<std::ptrdiff_t>(std::min(kBatch, kept.size() - first));
#pragma omp parallel for schedule(dynamic, 1)
    for (std::ptrdiff_t k = 0; k < count; ++k) {
      const Sweep& sw = kept[first + static_cast<std::size_t>(k)];
      clouds[static_cast<std::size_t>(k)] =
          simulate_scan(scene, lidar, sw.start, sw.end, options.noise, mix_key(noise_seed, sw.index));
    }
    for (std::size_t k = 0; k < static_cast<std::size_t>(count); ++k) {
      const Sweep& sw = kept[first + k];
      writer.add(sw.time, clouds[k], sw.end, sw.odom_T_sensor);
      ++summary.scans;
      summary.points += clouds[k].size();
      if (options.progress) options.progress(summary.scans, kept.size());
    }
  }
  writer.close();

  summary.route_length_m = route.length();
  summary.duration_s = route.duration();
  summary.traversable_area_m2 = grid.free_area();
  write_description(out_dir / "simulation.json", options, scene_description, mesh, lidar, robot, route, obstacles,
                    sweeps, summary);
  summary.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return summary;
}

}  // namespace tsdf_mcl::sim
