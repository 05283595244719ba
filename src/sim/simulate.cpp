#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <optional>
#include <vector>

#include "tsdf_mcl/sim/crowd.hpp"
#include "tsdf_mcl/sim/platform.hpp"
#include "tsdf_mcl/sim/random.hpp"
#include "tsdf_mcl/sim/route.hpp"
#include "run_description.hpp"
#include "shapes.hpp"
#include "tsdf_mcl/sim/traversability.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

namespace fs = std::filesystem;
using Eigen::Vector2d;
using Eigen::Vector3d;
using Eigen::Vector3f;

namespace {

constexpr double kDefaultTestLength = 60.0;  // m, when neither a duration nor a length is given
constexpr double kOpenAirCoverage = 10.0;    // m from any street point to a mapping route's waypoint
constexpr double kObstacleSize = 0.5;        // m, footprint of a standing person
constexpr double kObstacleHeight = 1.8;
constexpr double kScanSpacingTurn = 30.0 * M_PI / 180.0;  // a turn that keeps a scan despite --scan_spacing

// Stream keys: one independent random stream per purpose.
enum Stream : std::uint64_t {
  kObstacleStream = 10,
  kOdometryStream = 11,
  kScanNoiseStream = 12,
  kPlatformStream = 13,
  kWalkerStream = 14
};

constexpr const char* kBuiltInScenes[] = {"office", "symmetric", "warehouse", "two-storey", "town"};
// Between the storeys of a mapping route the robot is carried (up the stairs): no scans in this time, nor in
// kPauseMargin either side of it (the platforms smooth their motion over a quarter second).
constexpr double kCarryPause = 5.0;   // s
constexpr double kPauseMargin = 0.5;  // s

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
  // Noise as large as the motion itself is already no odometry; beyond, the drift leaves every map (1e300: NaN).
  require(n.relative <= 1.0 && n.rotation_per_meter <= 10.0 && n.translation_floor <= 1.0 && n.rotation_floor <= 1.0,
          "odometry noise must be at most 1 (--odom_noise: sigma as large as the motion)");
  require(o.duration_s >= 0.0 && o.length_m >= 0.0, "duration and length must not be negative");
  require(o.duration_s == 0.0 || o.length_m == 0.0, "give a duration or a length, not both");
  // Spacing below a centimetre keeps every sweep anyway (the platforms move more per sweep).
  require(o.scan_spacing_m == 0.0 || (o.scan_spacing_m >= 0.01 && o.scan_spacing_m <= 100.0),
          "scan spacing must be 0 (every sweep) or in [0.01, 100] m");
  require(o.obstacles == 0 || o.route == RouteKind::test,
          "obstacles are unmapped objects: they belong in test runs, not in the mapping run");
  require(o.obstacles <= 1000, "at most 1000 obstacles");
  require(o.walkers == 0 || o.route == RouteKind::test,
          "walkers are unmapped people: they belong in test runs, not in the mapping run");
  require(o.walkers <= 50, "at most 50 walkers");
  require(!std::isinf(o.ground_plane_z), "ground plane height must be finite");
  require(std::isfinite(o.scene_size_m) && o.scene_size_m >= 0.0, "the scene size must be finite and not negative");
  require(std::abs(o.sensor_tilt_deg) <= 90.0, "sensor tilt must be within [-90, 90] deg");
  require((!o.start && o.waypoints.empty()) || o.route == RouteKind::test,
          "a start and waypoints shape test routes; a mapping route covers the whole floor");
  require(!o.start || o.start->allFinite(), "the route start must be finite");
  for (const Eigen::Vector2d& w : o.waypoints) require(w.allFinite(), "waypoints must be finite");
  require(o.skip_areas.empty() || o.route == RouteKind::mapping, "skip areas shape mapping routes, not test routes");
  for (const auto& [lo, hi] : o.skip_areas) {
    require(lo.allFinite() && hi.allFinite() && (lo.array() < hi.array()).all(),
            "a skip area needs finite X0 < X1 and Y0 < Y1");
  }
}

bool is_built_in(const std::string& scene) {
  return std::find(std::begin(kBuiltInScenes), std::end(kBuiltInScenes), scene) != std::end(kBuiltInScenes);
}

BuiltInScene load_scene(const SimulationOptions& o) {
  BuiltInScene scene;
  if (is_built_in(o.scene)) {
    scene = built_in_scene(o.scene, o.scene_seed, o.scene_size_m);
  } else {
    if (!fs::is_regular_file(o.scene)) {
      throw Error("scene '" + o.scene +
                  "' is neither a built-in scene (office, symmetric, warehouse, two-storey, town) nor an existing mesh "
                  "file");
    }
    if (o.scene_size_m != 0.0) throw Error("a scene size applies to the built-in town only, not to a mesh file");
    scene.mesh = load_mesh(o.scene);
    if (scene.mesh.triangles.empty()) throw Error("mesh " + o.scene + " has no triangles");
    scene.description = o.scene;
  }
  if (!std::isnan(o.ground_plane_z)) {
    const Vector3f lo = scene.mesh.min_corner(), hi = scene.mesh.max_corner();
    const auto z = static_cast<float>(o.ground_plane_z);
    add_box(scene.mesh, Vector3f(lo.x() - 0.5f, lo.y() - 0.5f, z - 0.1f), Vector3f(hi.x() + 0.5f, hi.y() + 0.5f, z));
  }
  return scene;
}

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
      // Separate statements: the order in which the operands of one expression are evaluated is unspecified (gcc
      // and clang differ), and the placement must not depend on the compiler (this is gcc's order).
      const double along = rng.uniform(-1.0, 1.0);
      const double across = rng.uniform(keep_off_route, 2.5);
      const Vector2d c = p + side * across * left + along * forward;
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

// Odometry: the true motion of one frame (the ground robot's base, or the sensor) between two scans,
// perturbed in proportion to its size, integrated from the frame's first pose in the odom frame.
class Odometry {
 public:
  Odometry(const OdometryNoise& noise, std::uint64_t seed, const Pose& odom_T_first)
      : noise_(noise), rng_(seed), odom_T_frame_(odom_T_first) {}

  Pose step(const Pose& world_T_frame) {
    if (!last_) {
      last_ = world_T_frame;
      return odom_T_frame_;
    }
    const Pose motion = last_->inverse() * world_T_frame;
    last_ = world_T_frame;
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
    odom_T_frame_ = orthonormalized(odom_T_frame_ * noisy);
    return odom_T_frame_;
  }

 private:
  OdometryNoise noise_;
  Rng rng_;
  std::optional<Pose> last_;
  Pose odom_T_frame_;
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

// Where the walkers are and how much of them each scan sees.
struct WalkerSightings {
  std::vector<std::size_t> points;                 // per scan, returns on walkers
  std::vector<std::vector<Eigen::Vector3f>> feet;  // per scan, each walker's foot point at the sweep's end
};

void write_landmark_points(const fs::path& file, const LandmarkSightings& seen) {
  std::ofstream out(file);
  for (std::size_t n : seen.points) out << n << "\n";
  if (!out) throw Error("cannot write " + file.string());
}

void write_walkers(const fs::path& file, const WalkerSightings& seen) {
  std::ofstream out(file);
  for (std::size_t i = 0; i < seen.points.size(); ++i) {
    out << seen.points[i];
    for (const Eigen::Vector3f& f : seen.feet[i]) out << ' ' << f.x() << ' ' << f.y() << ' ' << f.z();
    out << "\n";
  }
  if (!out) throw Error("cannot write " + file.string());
}

std::size_t points_on(const Landmark& landmark, const std::vector<int>& triangles) {
  const auto first = static_cast<int>(landmark.first_triangle);
  const auto end = static_cast<int>(landmark.first_triangle + landmark.triangle_count);
  return static_cast<std::size_t>(
      std::count_if(triangles.begin(), triangles.end(), [&](int t) { return t >= first && t < end; }));
}

// A sweep that becomes a scan: its index and end time, the sensor's poses at its start and end, the odometry at
// its end, the walkers during it.
struct Sweep {
  std::size_t index;
  double time;
  Pose start, end, odom_T_sensor;
  std::vector<Walker> walkers;
};

// Which sweeps become scans, and their poses: sequential, as odometry integrates every sweep.
std::vector<Sweep> plan_sweeps(const SimulationOptions& options, const Route& route, const SensorTrajectory& trajectory,
                               const Crowd& crowd, std::size_t sweeps, double period) {
  std::vector<Sweep> kept;
  Odometry odometry(options.odometry, mix_key(options.seed, kOdometryStream), trajectory.first_odometry_pose(period));
  for (std::size_t i = 0; i < sweeps; ++i) {
    const double t = static_cast<double>(i + 1) * period;
    const Pose sensor_end = trajectory.sensor_pose(t);
    const Pose odom_T_sensor = odometry.step(trajectory.odometry_frame_pose(t)) * trajectory.odometry_frame_T_sensor();
    if (route.overlaps_pause(t - period - kPauseMargin, t + kPauseMargin)) continue;  // carried between storeys
    if (!kept.empty() && options.scan_spacing_m > 0.0) {
      const Pose moved = kept.back().end.inverse() * sensor_end;
      if (moved.translation().norm() < options.scan_spacing_m &&
          Eigen::AngleAxisd(moved.linear()).angle() < kScanSpacingTurn) {
        continue;
      }
    }
    const double start_time = options.motion_distortion ? t - period : t;
    kept.push_back({i, t, trajectory.sensor_pose(start_time), sensor_end, odom_T_sensor, crowd.during(start_time, t)});
  }
  return kept;
}

// What the scans showed: the summary's counts, the landmark's and the walkers' points per scan.
struct ScanResults {
  SimulationSummary summary;
  LandmarkSightings sightings;
  WalkerSightings walker_sightings;
};

// The kept sweeps simulated and written, each scan reported to options.on_scan and options.progress.
ScanResults write_scans(const SimulationOptions& options, const RayCaster& ray_caster, const LidarModel& lidar,
                        const BuiltInScene& scene, const Route& route, const SensorTrajectory& trajectory,
                        const std::vector<Sweep>& kept, const fs::path& out_dir) {
  ScanResults results;
  SimulationSummary& summary = results.summary;
  LandmarkSightings& sightings = results.sightings;
  WalkerSightings& walker_sightings = results.walker_sightings;
  // Scans in batches, one scan per thread: a fork and join per batch rather than per scan keeps both cores
  // busy even when other processes compete for them.
  DatasetWriter writer(out_dir);
  const std::uint64_t noise_seed = mix_key(options.seed, kScanNoiseStream);
  const bool label_points = scene.landmark || options.walkers > 0;
  constexpr std::size_t kBatch = 32;
  std::vector<PointCloud> clouds(kBatch);
  std::vector<std::vector<int>> triangles(kBatch);
  std::vector<std::vector<std::uint16_t>> rings(options.on_scan ? kBatch : 0);
  for (std::size_t first = 0; first < kept.size(); first += kBatch) {
    const auto count = static_cast<std::ptrdiff_t>(std::min(kBatch, kept.size() - first));
#pragma omp parallel for schedule(dynamic, 1)
    for (std::ptrdiff_t k = 0; k < count; ++k) {
      const Sweep& sw = kept[first + static_cast<std::size_t>(k)];
      const auto slot = static_cast<std::size_t>(k);
      clouds[slot] = simulate_scan(
          ray_caster, lidar, sw.start, sw.end, options.noise, mix_key(noise_seed, sw.index),
          {sw.walkers, label_points ? &triangles[slot] : nullptr, options.on_scan ? &rings[slot] : nullptr});
    }
    for (std::size_t k = 0; k < static_cast<std::size_t>(count); ++k) {
      const Sweep& sw = kept[first + k];
      writer.add(sw.time, clouds[k], sw.end, sw.odom_T_sensor);
      if (options.on_scan) {
        options.on_scan(
            {sw.time, &clouds[k], &rings[k], sw.end, sw.odom_T_sensor, trajectory.odometry_frame_T_sensor()});
      }
      if (scene.landmark) {
        sightings.points.push_back(points_on(*scene.landmark, triangles[k]));
        if (!sightings.first_scan && sightings.points.back() > 0) {
          sightings.first_scan = summary.scans;
          sightings.first_time_s = sw.time;
          sightings.first_distance_m = route.distance_at(sw.time);
        }
      }
      if (options.walkers > 0) {
        walker_sightings.points.push_back(
            static_cast<std::size_t>(std::count(triangles[k].begin(), triangles[k].end(), -1)));
        std::vector<Eigen::Vector3f> feet;
        for (const Walker& w : sw.walkers) feet.push_back(w.end);
        walker_sightings.feet.push_back(std::move(feet));
      }
      ++summary.scans;
      summary.points += clouds[k].size();
      if (options.progress) options.progress(summary.scans, kept.size());
    }
  }
  writer.close();
  return results;
}

}  // namespace

SimulationSummary simulate(const SimulationOptions& options, const fs::path& out_dir) {
  const auto wall_start = std::chrono::steady_clock::now();
  validate(options);
  const LidarModel lidar = LidarModel::from_name(options.lidar, options.rate_hz);
  check_output_dir(out_dir);

  BuiltInScene scene = load_scene(options);
  TriangleMesh& mesh = scene.mesh;
  const bool open_air = scene.open_air || options.open_air;
  const RayCaster static_scene(mesh);
  // The sensor must not poke into what the robot drives under (the drone keeps its own headroom).
  RobotModel robot = options.robot;
  if (options.platform != Platform::drone) robot.height = std::max(robot.height, robot.sensor_height + 0.1);
  const double min_floor =
      std::isnan(options.ground_plane_z) ? -std::numeric_limits<double>::infinity() : options.ground_plane_z - 0.01;
  const std::size_t storeys = std::max<std::size_t>(1, scene.storey_floors.size());
  if (options.storey >= storeys) {
    throw Error("storey " + std::to_string(options.storey) + ": the scene has " +
                (storeys == 1 ? std::string("one storey (0)")
                              : std::to_string(storeys) + " storeys (0 to " + std::to_string(storeys - 1) + ")"));
  }
  // Each storey's traversable floor: the lowest floor from the storey's height up. A test route runs on one
  // storey, a mapping route covers each in turn.
  std::vector<TraversabilityGrid> grids;
  const bool mapping = options.route == RouteKind::mapping;
  for (std::size_t k = mapping ? 0 : options.storey; k < (mapping ? storeys : options.storey + 1); ++k) {
    grids.emplace_back(static_scene, mesh, robot, 0.1, k == 0 ? min_floor : scene.storey_floors[k] - 0.01, open_air);
    grids.back().exclude(options.skip_areas);
  }
  const TraversabilityGrid& grid = grids.front();  // where walkers and obstacles go (test routes only)

  // A test route is planned at least as long as the run (requested waypoints say where it ends); a mapping
  // route covers the floor.
  double stop_length = options.length_m;
  if (options.route == RouteKind::test && options.length_m == 0.0 && options.duration_s == 0.0 &&
      options.waypoints.empty()) {
    stop_length = kDefaultTestLength;
  }
  const double plan_length = options.duration_s > 0.0 ? options.duration_s * robot.speed + 5.0 : stop_length;
  RouteRequest request{options.start, options.waypoints, std::nullopt};
  if (scene.landmark) request.landmark = scene.landmark->viewpoint;
  // Outdoors a test route may start on any street, and a mapping route drives each street once.
  request.via_ramp = !open_air;
  if (open_air) request.coverage_radius = kOpenAirCoverage;
  std::vector<Route> parts;
  for (const TraversabilityGrid& g : grids) {
    parts.push_back(plan_route(g, static_scene, robot, options.route, options.seed, plan_length, request));
  }
  const Route route = (parts.size() == 1 ? parts.front() : Route::joined(parts, kCarryPause))
                          .truncated(options.duration_s, stop_length);
  const SensorTrajectory trajectory(route, static_scene, options.platform, robot, options.sensor_tilt_deg,
                                    mix_key(options.seed, kPlatformStream));
  const Crowd crowd(grid, static_scene, route, options.walkers, mix_key(options.seed, kWalkerStream));

  Rng obstacle_rng(mix_key(options.seed, kObstacleStream));
  const std::vector<Obstacle> obstacles = place_obstacles(grid, route, robot, options.obstacles, obstacle_rng);
  for (const Obstacle& o : obstacles) add_box(mesh, o.min, o.max);
  const RayCaster ray_caster(mesh);
  save_mesh_ply(mesh, out_dir / "scene.ply");

  const double period = 1.0 / lidar.rate_hz;
  const auto sweeps = static_cast<std::size_t>(std::floor(route.duration() / period + 1e-9));
  if (sweeps == 0) throw Error("the route takes less than one scan period; ask for a longer duration or length");

  const std::vector<Sweep> kept = plan_sweeps(options, route, trajectory, crowd, sweeps, period);

  ScanResults results = write_scans(options, ray_caster, lidar, scene, route, trajectory, kept, out_dir);
  SimulationSummary& summary = results.summary;
  const LandmarkSightings& sightings = results.sightings;
  summary.route_length_m = route.length();
  summary.duration_s = route.duration();
  for (const TraversabilityGrid& g : grids) summary.traversable_area_m2 += g.free_area();
  summary.has_landmark = scene.landmark.has_value();
  summary.landmark_first_seen_scan = sightings.first_scan;
  if (scene.landmark) write_landmark_points(out_dir / "landmark_points.txt", sightings);
  if (options.walkers > 0) write_walkers(out_dir / "walkers.txt", results.walker_sightings);
  write_description(out_dir / "simulation.json",
                    {options, scene, lidar, robot, route, obstacles, sightings, crowd, sweeps, summary});
  summary.wall_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return summary;
}

}  // namespace tsdf_mcl::sim
