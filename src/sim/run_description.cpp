#include "run_description.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/sim/platform.hpp"

namespace tsdf_mcl::sim {

namespace fs = std::filesystem;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {

nlohmann::json pose_json(const Pose& p) {
  const Vector3d rpy = rpy_of(p.linear());
  return {{"x", p.translation().x()}, {"y", p.translation().y()}, {"z", p.translation().z()},
          {"roll", rpy.x()},          {"pitch", rpy.y()},         {"yaw", rpy.z()}};
}

nlohmann::json kitti_json(const Pose& p) {
  const auto k = kitti_of(p);
  return {{k[0], k[1], k[2], k[3]}, {k[4], k[5], k[6], k[7]}, {k[8], k[9], k[10], k[11]}};
}

nlohmann::json scene_json(const RunRecord& r) {
  const SimulationOptions& o = r.options;
  const TriangleMesh& mesh = r.scene.mesh;
  nlohmann::json j = {
      {"source", o.scene},
      {"description", r.scene.description},
      {"scene_seed", o.scene_seed},
      {"ground_plane_z", std::isnan(o.ground_plane_z) ? nlohmann::json() : nlohmann::json(o.ground_plane_z)},
      {"triangles", mesh.triangles.size()},
      {"min", {mesh.min_corner().x(), mesh.min_corner().y(), mesh.min_corner().z()}},
      {"max", {mesh.max_corner().x(), mesh.max_corner().y(), mesh.max_corner().z()}},
      {"traversable_area_m2", r.summary.traversable_area_m2},
      {"file", "scene.ply"}};
  if (!r.scene.storey_floors.empty()) j["storey_floors"] = r.scene.storey_floors;
  // Open-air scenes only, so that the other scenes' descriptions stay as they were.
  if (r.scene.open_air || o.open_air) j["open_air"] = true;
  if (!r.scene.streets.empty()) {
    nlohmann::json streets = nlohmann::json::array();
    for (const Eigen::AlignedBox2f& s : r.scene.streets)
      streets.push_back({s.min().x(), s.min().y(), s.max().x(), s.max().y()});
    j["streets"] = {{"carriageways", streets}, {"note", "x0, y0, x1, y1 (m) of each street's carriageway"}};
  }
  if (r.scene.mirror) {
    const Vector2d centre = r.scene.mirror->translation().head<2>() / 2.0;
    char rule[320];
    std::snprintf(rule, sizeof(rule),
                  "half turn about the vertical through (%g, %g): (x, y, z, roll, pitch, yaw) -> (%g - x, %g - y, z, "
                  "roll, pitch, yaw + 180 deg); mirror pose = world_T_mirror * world_T_sensor",
                  centre.x(), centre.y(), 2.0 * centre.x(), 2.0 * centre.y());
    j["symmetry"] = {{"world_T_mirror", kitti_json(*r.scene.mirror)}, {"rule", rule}};
  }
  return j;
}

nlohmann::json landmark_json(const Landmark& l, const LandmarkSightings& seen) {
  const auto first = [&](auto value) { return seen.first_scan ? nlohmann::json(value) : nlohmann::json(); };
  return {{"name", l.name},
          {"min", {l.box.min().x(), l.box.min().y(), l.box.min().z()}},
          {"max", {l.box.max().x(), l.box.max().y(), l.box.max().z()}},
          {"triangles", {l.first_triangle, l.first_triangle + l.triangle_count}},
          {"viewpoint", {l.viewpoint.x(), l.viewpoint.y()}},
          {"first_seen_scan", first(seen.first_scan.value_or(0))},
          {"first_seen_time_s", first(seen.first_time_s)},
          {"first_seen_distance_m", first(seen.first_distance_m)},
          {"scans_seeing", std::count_if(seen.points.begin(), seen.points.end(), [](std::size_t n) { return n > 0; })},
          {"file", "landmark_points.txt: per scan, the returns on the landmark"}};
}

nlohmann::json crowd_json(const Crowd& crowd) {
  nlohmann::json people = nlohmann::json::array();
  for (const Crowd::Person& p : crowd.people()) {
    nlohmann::json stops = nlohmann::json::array();
    for (const Vector2d& w : p.waypoints) stops.push_back({w.x(), w.y()});
    people.push_back({{"speed", p.speed}, {"waypoints", stops}});
  }
  const Walker shape;
  return {
      {"radius", shape.radius},
      {"height", shape.height},
      {"give_way_m", Crowd::kGiveWay},
      {"people", people},
      {"file", "walkers.txt: per scan, the returns on walkers, then x y z of each walker's foot at the sweep's end"}};
}

nlohmann::json platform_json(const SimulationOptions& o) {
  nlohmann::json j = {{"sensor_tilt_deg", o.sensor_tilt_deg}};
  switch (o.platform) {
    case Platform::ground:
      j["kind"] = "ground";
      break;
    case Platform::handheld:
      j["kind"] = "handheld";
      j["gait"] = {{"step_length", Gait::kStepLength}, {"bob", Gait::kBob},        {"roll_deg", Gait::kRollDeg},
                   {"pitch_deg", Gait::kPitchDeg},     {"yaw_deg", Gait::kYawDeg}, {"drift_deg", Gait::kDriftDeg}};
      break;
    case Platform::drone:
      j["kind"] = "drone";
      j["flight"] = {{"min_height", Flight::kMinHeight},    {"max_height", Flight::kMaxHeight},
                     {"lowest", Flight::kLowest},           {"headroom", Flight::kHeadroom},
                     {"max_tilt_deg", Flight::kMaxTiltDeg}, {"max_yaw_offset_deg", Flight::kMaxYawOffsetDeg}};
      break;
  }
  return j;
}

nlohmann::json route_json(const RunRecord& r) {
  const SimulationOptions& o = r.options;
  nlohmann::json waypoints = nlohmann::json::array();
  for (const Vector2d& w : r.route.waypoints()) waypoints.push_back({w.x(), w.y()});
  nlohmann::json j = {{"kind", o.route == RouteKind::mapping ? "mapping" : "test"},
                      {"seed", o.seed},
                      {"duration_limit_s", o.duration_s},
                      {"length_limit_m", o.length_m},
                      {"scan_spacing_m", o.scan_spacing_m},
                      {"length_m", r.route.length()},
                      {"duration_s", r.route.duration()},
                      {"waypoints", waypoints},
                      {"start", pose_json(r.route.samples().front().world_T_base)}};
  if (!r.scene.storey_floors.empty() && o.route == RouteKind::test) j["storey"] = o.storey;
  if (!r.route.pauses().empty()) {
    nlohmann::json pauses = nlohmann::json::array();
    for (const auto& [from, to] : r.route.pauses()) pauses.push_back({from, to});
    j["carried"] = {{"intervals_s", pauses}, {"note", "carried between storeys: no scans then, nor 0.5 s either side"}};
  }
  if (o.start) j["requested_start"] = {o.start->x(), o.start->y(), o.start->z()};
  if (!o.waypoints.empty()) {
    nlohmann::json requested = nlohmann::json::array();
    for (const Vector2d& w : o.waypoints) requested.push_back({w.x(), w.y()});
    j["requested_waypoints"] = requested;
  }
  return j;
}

}  // namespace

void write_description(const fs::path& file, const RunRecord& r) {
  const SimulationOptions& o = r.options;
  const RobotModel& robot = r.robot;
  nlohmann::json j;
  j["scene"] = scene_json(r);
  j["lidar"] = {{"name", r.lidar.name},
                {"elevations_deg", r.lidar.elevations_deg},
                {"columns", r.lidar.columns},
                {"min_range", r.lidar.min_range},
                {"max_range", r.lidar.max_range},
                {"rate_hz", r.lidar.rate_hz},
                {"spin", "clockwise seen from above, column 0 along +x"},
                {"range_sigma", o.noise.range_sigma},
                {"dropout", o.noise.dropout},
                {"motion_distortion", o.motion_distortion}};
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
  j["platform"] = platform_json(o);
  j["odometry"] = {
      {"relative", o.odometry.relative},
      {"rotation_per_meter", o.odometry.rotation_per_meter},
      {"translation_floor", o.odometry.translation_floor},
      {"rotation_floor", o.odometry.rotation_floor},
      {"frame", o.platform == Platform::ground
                    ? "odom_T_sensor; the odom frame is the base's first pose"
                    : "odom_T_sensor from the sensor's own motion; the odom frame is the base's first pose"}};
  j["route"] = route_json(r);
  if (r.scene.landmark) j["landmark"] = landmark_json(*r.scene.landmark, r.sightings);
  nlohmann::json boxes = nlohmann::json::array();
  for (const Obstacle& b : r.obstacles) {
    boxes.push_back({{"min", {b.min.x(), b.min.y(), b.min.z()}}, {"max", {b.max.x(), b.max.y(), b.max.z()}}});
  }
  j["obstacles"] = boxes;
  if (!r.crowd.people().empty()) j["walkers"] = crowd_json(r.crowd);
  j["counts"] = {{"sweeps", r.sweeps}, {"scans", r.summary.scans}, {"points", r.summary.points}};
  j["files"] = {{"scans", "scans/NNNNNN.bin: float32 x y z intensity, sensor frame"},
                {"times", "times.txt: end of each sweep (s)"},
                {"poses", "poses.txt: world_T_sensor at the end of each sweep, KITTI 3x4"},
                {"odometry", "odom.txt: odom_T_sensor, KITTI 3x4"}};
  write_file_atomically(file, j.dump(2) + "\n", "simulation description");
}

}  // namespace tsdf_mcl::sim
