#pragma once
// LiDAR simulation: spinning multi-beam LiDAR models, ray casting against triangle meshes, the built-in
// office scene, and whole runs of a ground robot driving a route, written as a dataset (DESIGN.md layout).
//
// Frames: world z up; the robot base sits on the floor (x forward, y left, z up); the sensor frame is the
// base frame lifted by RobotModel::sensor_height. Poses are world_T_sensor unless a name says otherwise.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "tsdf_mcl/mesh.hpp"
#include "tsdf_mcl/point_cloud.hpp"
#include "tsdf_mcl/pose.hpp"

namespace tsdf_mcl::sim {

// A spinning LiDAR: beams at fixed elevations, fired at `columns` equally spaced azimuths per revolution.
// The head spins clockwise seen from above (as Velodyne and Ouster heads do); column 0 looks along +x, so
// column c looks at azimuth -2*pi*c/columns.
//
// Beam table file (--lidar FILE): text, '#' starts a comment, one entry per line:
//   columns 1024        azimuth steps per revolution (required)
//   min_range 0.3       metres (required)
//   max_range 50        metres (required)
//   rate 10             revolutions per second (optional, default 10)
//   name my-lidar       (optional, default: the file's stem)
//   -15.5               a line holding a single number is one beam's elevation in degrees
struct LidarModel {
  std::string name;
  std::vector<double> elevations_deg;  // one per beam, ascending
  int columns = 0;
  double min_range = 0.0;  // m; closer returns are dropped, as a driver does
  double max_range = 0.0;  // m; farther surfaces give no return
  double rate_hz = 10.0;   // revolutions per second

  // Velodyne VLP-16: 16 beams at -15..+15 deg every 2 deg, 0.5-100 m, 5-20 Hz; the azimuth step follows
  // the rate (0.2 deg at 10 Hz = 1800 columns, 0.4 deg at 20 Hz = 900 columns).
  static LidarModel vlp16(double rate_hz = 20.0);
  // Ouster OS0-64: 64 beams evenly over -45..+45 deg, 1024 columns, 0.3-50 m, 10 or 20 Hz.
  static LidarModel os0_64(double rate_hz = 10.0);
  static LidarModel from_beam_table(const std::filesystem::path& file);
  // "vlp16", "os0-64" or a beam table file; rate_hz > 0 replaces the model's own rate.
  static LidarModel from_name(const std::string& name_or_file, double rate_hz = 0.0);

  std::size_t beams() const { return elevations_deg.size(); }
  std::size_t rays() const { return beams() * static_cast<std::size_t>(columns); }
  double azimuth_of(int column) const;                    // rad
  Eigen::Vector3f direction(int beam, int column) const;  // unit vector, sensor frame
};

struct ScanNoise {
  double range_sigma = 0.015;  // m, Gaussian along the beam
  double dropout = 0.0;        // probability that a return is lost
};

// Closest-hit ray queries against a triangle mesh (an Embree BVH). Queries are thread-safe.
class RayCaster {
 public:
  struct Hit {
    float distance = std::numeric_limits<float>::infinity();  // infinity: no hit within the limit
    Eigen::Vector3f normal = Eigen::Vector3f::Zero();         // unit, facing the ray's origin
    int triangle = -1;                                        // index into the mesh's triangles
    bool hit() const { return distance < std::numeric_limits<float>::infinity(); }
  };

  explicit RayCaster(const TriangleMesh& mesh);  // throws Error for an empty mesh or non-finite vertices
  ~RayCaster();
  RayCaster(RayCaster&&) noexcept;
  RayCaster& operator=(RayCaster&&) noexcept;

  Hit cast(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction, float max_distance,
           float min_distance = 0.0f) const;
  // Rays sharing one origin (one LiDAR column), traced as packets; directions are unit vectors.
  void cast_fan(const Eigen::Vector3f& origin, const Eigen::Vector3f* directions, std::size_t count, float min_distance,
                float max_distance, Hit* hits) const;

  Eigen::AlignedBox3f bounds() const;
  std::size_t triangle_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// One sweep of a spinning LiDAR; points in the end-of-sweep sensor frame, column by column, intensity =
// |cos| of the incidence angle. Column c fires at fraction (c + 1) / columns of the sweep from the pose
// interpolated between sweep_start and sweep_end (pass the same pose twice for no motion distortion).
// Rays that hit nothing within max_range, land closer than min_range or drop out give no point.
// noise_key picks the noise: the same key gives the same scan whatever the number of threads.
PointCloud simulate_scan(const RayCaster& scene, const LidarModel& lidar, const Pose& sweep_start,
                         const Pose& sweep_end, const ScanNoise& noise, std::uint64_t noise_key);

// The built-in office: a closed ~50 x 20 m floor with a 3 m ceiling, rooms of several sizes on both sides
// of a corridor, doors, pillars and furniture, a corridor ramp (7 deg) up to a raised east wing and a ramp
// (8.5 deg) up to a platform in the west hall. Built from overlapping closed solids with outward normals.
// The seed places the furniture; the same seed gives the same mesh.
TriangleMesh office_scene(std::uint64_t seed = 1);

// The ground robot that carries the sensor.
struct RobotModel {
  double radius = 0.3;            // m, footprint for clearance checks
  double height = 1.0;            // m of free space it needs above the floor (simulate: at least the sensor's + 0.1)
  double max_step = 0.05;         // m, largest floor step it drives over
  double max_slope_deg = 15.0;    // steepest floor it drives on
  double wheelbase = 0.5;         // m, front-back distance of the contact points that set the pitch
  double track = 0.4;             // m, left-right distance of the contact points that set the roll
  double sensor_height = 0.5;     // m, sensor origin above the base
  double speed = 0.8;             // m/s, cruise speed
  double max_turn_rate = 1.0;     // rad/s; the robot slows down in curves and turns on the spot at cusps
  double max_acceleration = 0.5;  // m/s^2
};

// Per sweep the true relative base motion (translation t, rotation angle a) is perturbed by Gaussian noise on
// every axis with sigma_t = relative * (|t| + translation_floor) and
// sigma_r = relative * (|a| + rotation_per_meter * |t| + rotation_floor), then integrated, so the track drifts.
struct OdometryNoise {
  double relative = 0.1;             // the paper's sigma on linear and angular velocity
  double rotation_per_meter = 0.2;   // rad/m: heading slips while driving straight
  double translation_floor = 0.005;  // m
  double rotation_floor = 0.005;     // rad
};

enum class RouteKind { mapping, test };

struct SimulationOptions {
  std::string scene = "office";  // "office" or a mesh file (STL/PLY/OBJ, metres, z up)
  std::uint64_t scene_seed = 1;  // furniture of the built-in office
  // Adds a closed ground slab with its top at this height under the mesh's footprint, for meshes without a
  // floor of their own (Gazebo worlds get theirs from a ground plane); NaN: none.
  double ground_plane_z = std::numeric_limits<double>::quiet_NaN();
  std::string lidar = "vlp16";  // "vlp16", "os0-64" or a beam table file
  double rate_hz = 0.0;         // 0: the LiDAR's own rate (VLP-16 20 Hz, OS0-64 10 Hz)
  RouteKind route = RouteKind::test;
  std::uint64_t seed = 1;  // route, obstacles and noise
  // Where to stop (give at most one): > 0 ends the run after this much simulated time or distance driven.
  // With neither, a test route ends after 60 m and a mapping route covers the whole floor.
  double duration_s = 0.0;
  double length_m = 0.0;
  RobotModel robot;
  ScanNoise noise;
  OdometryNoise odometry;
  // Keep a sweep only once the sensor moved this far (m) or turned 30 deg since the last kept one; 0 keeps
  // every sweep. A mapping run needs no 20 scans a second: its scans only build the map.
  double scan_spacing_m = 0.0;
  std::size_t obstacles = 0;  // unmapped people-sized boxes near a test route
  bool motion_distortion = false;
  std::function<void(std::size_t written, std::size_t total)> progress;  // called after each scan written
};

struct SimulationSummary {
  std::size_t scans = 0;
  std::size_t points = 0;
  double route_length_m = 0.0;
  double duration_s = 0.0;  // simulated time
  double traversable_area_m2 = 0.0;
  double wall_time_s = 0.0;
};

// Builds the scene, finds the traversable floor (the largest connected free region, enclosed floor first),
// plans and drives the route, places the obstacles beside it, and writes DIR/scans/, times.txt, poses.txt
// (world_T_sensor), odom.txt (odom_T_sensor), scene.ply (with the obstacles) and simulation.json (every parameter and
// count). Throws Error naming what is at fault.
SimulationSummary simulate(const SimulationOptions& options, const std::filesystem::path& out_dir);

}  // namespace tsdf_mcl::sim
