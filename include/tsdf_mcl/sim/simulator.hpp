#pragma once
// LiDAR simulation: spinning multi-beam LiDAR models, ray casting against triangle meshes, the built-in
// scenes (office, symmetric building, warehouse, two storeys, an open-air town), and whole runs of a ground robot, a
// walking person or a drone carrying the sensor along a route, written as a dataset (docs/architecture.md layout).
//
// Frames: world z up; the robot base sits on the floor (x forward, y left, z up); the ground robot's sensor
// frame is the base frame lifted by RobotModel::sensor_height. Poses are world_T_sensor unless a name says
// otherwise.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tsdf_mcl/io/mesh.hpp"
#include "tsdf_mcl/core/point_cloud.hpp"
#include "tsdf_mcl/core/pose.hpp"

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

// A person walking through a sweep: a vertical cylinder standing on the floor, its foot point moving
// linearly from `start` to `end` over the sweep (the same for a person standing still).
struct Walker {
  Eigen::Vector3f start = Eigen::Vector3f::Zero(), end = Eigen::Vector3f::Zero();
  float radius = 0.25f;
  float height = 1.75f;
};

// What a scan may see and tell besides the scene.
struct ScanExtras {
  std::vector<Walker> walkers;                  // unmapped people
  std::vector<int>* hit_triangles = nullptr;    // receives each point's triangle in the scene's mesh, -1 on a walker
  std::vector<std::uint16_t>* rings = nullptr;  // receives each point's beam, 0 = the lowest (Velodyne's ring)
};

// One sweep of a spinning LiDAR; points in the end-of-sweep sensor frame, column by column, intensity =
// |cos| of the incidence angle. Column c fires at fraction (c + 1) / columns of the sweep from the pose
// interpolated between sweep_start and sweep_end (pass the same pose twice for no motion distortion), and
// sees the walkers where they are at that fraction. Rays that hit nothing within max_range, land closer than
// min_range or drop out give no point. noise_key picks the noise: the same key gives the same scan
// whatever the number of threads.
PointCloud simulate_scan(const RayCaster& scene, const LidarModel& lidar, const Pose& sweep_start,
                         const Pose& sweep_end, const ScanNoise& noise, std::uint64_t noise_key,
                         const ScanExtras& extras = {});

// The built-in office: a closed ~50 x 20 m floor with a 3 m ceiling, rooms of several sizes on both sides
// of a corridor, doors, pillars and furniture, a corridor ramp (7 deg) up to a raised east wing and a ramp
// (8.5 deg) up to a platform in the west hall. Built from overlapping closed solids with outward normals.
// The seed places the furniture; the same seed gives the same mesh.
TriangleMesh office_scene(std::uint64_t seed = 1);

// The one feature of a building that tells its look-alike parts apart (mirror-image wings, storeys of one plan).
struct Landmark {
  std::string name;
  Eigen::AlignedBox3f box;                              // m, world frame
  std::size_t first_triangle = 0, triangle_count = 0;   // its triangles in the scene's mesh
  Eigen::Vector2d viewpoint = Eigen::Vector2d::Zero();  // a floor point from where it fills the view
};

// A built-in building and what tests need to know about it.
struct BuiltInScene {
  TriangleMesh mesh;
  std::string description;
  // The building's symmetry, where it has one: from mirror * world_T_sensor the sensor sees exactly what it
  // sees from world_T_sensor, except where the landmark is in view.
  std::optional<Pose> mirror;
  std::optional<Landmark> landmark;
  // Floor heights of the storeys, lowest first (m); empty: one storey. simulate plans a test route on one storey
  // and a mapping route over each in turn.
  std::vector<float> storey_floors;
  // Open air (the town): the traversable floor is the largest connected region; indoors it is the most enclosed.
  bool open_air = false;
  // The carriageways of a scene with streets (x, y rectangles, m): every street point a route may use.
  std::vector<Eigen::AlignedBox2f> streets;
};

// Two identical wings (x 0..14 and 26..40 m) either side of a lobby, 40 x 16 m, 3 m ceiling: the building
// maps onto itself when turned by 180 deg about the vertical through (20, 8), so mirror = that half turn,
// (x, y, z, yaw) -> (40 - x, 16 - y, z, yaw + 180 deg). The landmark, a 1.2 x 0.6 x 1.6 m display cabinet
// in the middle south room of the east wing (x 32.6..33.8, y 2.6..3.2), has no image. The seed places the
// furniture (the same in both wings).
BuiltInScene symmetric_scene(std::uint64_t seed = 1);

// A 40 x 25 m warehouse hall, 7 m high: fourteen rows of pallet racks (y 8..22 m) with 3.2 m aisles, a cross
// aisle along the north wall, the loading dock along the south wall (four closed dock doors, a staging area
// with columns and pallets). The seed decides which rack slots hold pallets, their loads, and the staging
// area's pallets.
TriangleMesh warehouse_scene(std::uint64_t seed = 1);

// The office on two storeys of one plan, furnished alike: the lower one's ceiling slab is the upper one's floor
// (z 3.2 m), and a staircase against the lab's south wall (x 28..33.6, y 0..1.1) rises through an opening in it,
// railed on its north side and west end above. The staircase (steps seen from below, railing and hole from above) is
// the landmark: nothing else tells the storeys apart. storey_floors = {0, 3.2}.
BuiltInScene two_storey_scene(std::uint64_t seed = 1);

// An open-air town on a size_m x size_m ground slab (x, y in [0, size_m], ground z = 0), no roof: a grid of
// streets (8-14 m carriageways) between blocks raised 0.15 m (the kerb), each holding box buildings 3-25 m high
// (rows around a courtyard, detached L-shaped or set-back buildings, a tower on a podium, a ring with an archway),
// a park or a parking lot; blocks of one size may share a design (look-alike streets). Street lamps, trees, signs,
// bins, parked cars along the kerbs; plazas raised 0.9 m with a 6 deg ramp up from the street on two sides; a
// verge with a hedge around the town. The seed decides the grid, the designs and the furniture; size_m is 80-400.
// open_air is set and `streets` holds the carriageways.
BuiltInScene town_scene(std::uint64_t seed = 1, double size_m = 120.0);

// "office", "symmetric", "warehouse", "two-storey" or "town" with its seed; size_m > 0 sets the town's extent
// (0: its default, 120 m; the other scenes have one size). Throws Error for another name or a size elsewhere.
BuiltInScene built_in_scene(const std::string& name, std::uint64_t seed, double size_m = 0.0);

// What carries the sensor along the route (docs/simulator.md has the figures):
//   ground:   a robot base that follows the floor (pitch and roll from the floor under its wheels), the
//             sensor RobotModel::sensor_height above it;
//   handheld: a walking person holds the sensor upright sensor_height above the floor, with the sway of the
//             gait: height bob, roll, pitch and yaw oscillations at the step frequency, slow drifts;
//   drone:    flies the route 1.0-2.5 m above the floor, the height varying smoothly and lower where the
//             headroom asks for it, tilted along its acceleration, its yaw turning away from the path at times
//             (sensor_height is not used).
// Routes are planned for the robot's footprint on the floor whatever the platform.
enum class Platform { ground, handheld, drone };

// The robot (or person, or drone) that carries the sensor: footprint and motion limits of the route.
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

  // The defaults of each platform: ground as above; handheld: sensor 1.5 m high, 1.2 m/s, 1.5 rad/s,
  // 0.8 m/s^2; drone: 1.5 m/s, 2 rad/s, 2.5 m/s^2.
  static RobotModel of(Platform platform);
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

// One scan as simulate() writes it, for SimulationOptions::on_scan (simulate --bag).
struct SimulatedScan {
  double time = 0.0;
  const PointCloud* cloud = nullptr;
  const std::vector<std::uint16_t>* rings = nullptr;  // one per point: its beam, 0 = the lowest
  Pose world_T_sensor = Pose::Identity();
  Pose odom_T_sensor = Pose::Identity();
  // The sensor on the frame the odometry measures: the ground robot's base (mounting height and tilt); identity
  // on the other platforms, whose odometry is the sensor's own.
  Pose base_T_sensor = Pose::Identity();
};

struct SimulationOptions {
  std::string scene = "office";  // a built-in scene (built_in_scene) or a mesh file (STL/PLY/OBJ, metres, z up)
  std::uint64_t scene_seed = 1;  // furniture of the built-in scenes
  double scene_size_m = 0.0;     // the town's extent (m, 80-400); 0: its default, 120 m
  // The traversable floor is the largest connected region, not the most enclosed one: a mesh of streets in the open
  // (built-in open-air scenes say so themselves).
  bool open_air = false;
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
  // Multi-storey scenes: the storey a test route runs on (0 the lowest). A mapping route covers every storey in
  // turn, carried from one to the next between scans.
  std::size_t storey = 0;
  Platform platform = Platform::ground;
  RobotModel robot;  // RobotModel::of(platform) gives the platform's defaults
  // Mounting tilt of the LiDAR about its own y axis (deg); positive turns its x axis towards the floor.
  double sensor_tilt_deg = 0.0;
  // Test routes: start here (x, y in m, yaw in rad) instead of where the seed says, and/or drive through
  // these floor points in order and stop at the last (no 60 m default then). Points within 1 m of the
  // traversable floor snap onto it; farther ones are an error.
  std::optional<Eigen::Vector3d> start;
  std::vector<Eigen::Vector2d> waypoints;
  // Mapping routes: never enter these x, y rectangles (min, max; m), e.g. rooms the mapping run skipped. The map
  // built from the run then leaves them unobserved but for what the sensor sees through their doors; a test route
  // that enters them tracks through unmapped space.
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> skip_areas;
  ScanNoise noise;
  OdometryNoise odometry;
  // Keep a sweep only once the sensor moved this far (m) or turned 30 deg since the last kept one; 0 keeps
  // every sweep. A mapping run needs no 20 scans a second: its scans only build the map.
  double scan_spacing_m = 0.0;
  std::size_t obstacles = 0;  // unmapped people-sized boxes near a test route
  std::size_t walkers = 0;    // unmapped people walking about a test run (docs/simulator.md)
  bool motion_distortion = false;
  std::function<void(std::size_t written, std::size_t total)> progress;  // called after each scan written
  std::function<void(const SimulatedScan&)> on_scan;  // called with each scan as it is written, in order
};

struct SimulationSummary {
  std::size_t scans = 0;
  std::size_t points = 0;
  double route_length_m = 0.0;
  double duration_s = 0.0;  // simulated time
  double traversable_area_m2 = 0.0;
  bool has_landmark = false;                            // the scene has a landmark (symmetric)
  std::optional<std::size_t> landmark_first_seen_scan;  // the first scan that sees it, if one does
  double wall_time_s = 0.0;
};

// Builds the scene, finds the traversable floor (the largest connected free region, enclosed floor first unless
// open air), plans and drives the route, carries the sensor along it on the platform, places the obstacles beside
// it, and writes DIR/scans/, times.txt, poses.txt (world_T_sensor), odom.txt (odom_T_sensor), scene.ply (with
// the obstacles), simulation.json (every parameter and count), for a scene with a landmark
// landmark_points.txt (per scan, the returns on it) and with walkers walkers.txt (per scan, the returns on
// them and where they are). Throws Error naming what is at fault.
SimulationSummary simulate(const SimulationOptions& options, const std::filesystem::path& out_dir);

}  // namespace tsdf_mcl::sim
