#pragma once
// Routes of a ground robot: waypoints chosen on the traversable floor, A* between them (preferring the
// middle of corridors and doors), smoothed, driven with speed, turn-rate and acceleration limits. The base
// pose follows the floor: z from the floor under the robot, pitch and roll from the floor heights under
// its front/back and left/right contact points, yaw from the path's tangent.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <tuple>
#include <utility>
#include <vector>

#include "tsdf_mcl/sim/traversability.hpp"
#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

class Route {
 public:
  struct Sample {
    double time = 0.0;      // s from the start
    double distance = 0.0;  // m driven
    Pose world_T_base = Pose::Identity();
  };

  Route(std::vector<Sample> samples, std::vector<Eigen::Vector2d> waypoints);

  double duration() const { return samples_.back().time; }
  double length() const { return samples_.back().distance; }
  Pose base_pose(double time) const;      // interpolated; clamped to the route's ends
  double distance_at(double time) const;  // m driven by then, likewise
  const std::vector<Sample>& samples() const { return samples_; }
  const std::vector<Eigen::Vector2d>& waypoints() const { return waypoints_; }
  // The first part, up to max_duration and max_length (<= 0: no limit).
  Route truncated(double max_duration, double max_length) const;

  // Routes driven one after the other with `pause` s between them, in which the robot is carried to the next
  // one's start (from one storey to the next): no sensor data belongs to a pause. Distances add up over the parts.
  static Route joined(const std::vector<Route>& parts, double pause);
  // The pauses (start, end; s), and whether [t0, t1] overlaps one.
  const std::vector<std::pair<double, double>>& pauses() const { return pauses_; }
  bool overlaps_pause(double t0, double t1) const;

 private:
  std::tuple<const Sample&, const Sample&, double> bracket(double time) const;
  std::vector<Sample> samples_;
  std::vector<Eigen::Vector2d> waypoints_;
  std::vector<std::pair<double, double>> pauses_;
};

// What a test route must do besides what the seed chooses.
struct RouteRequest {
  std::optional<Eigen::Vector3d> start;     // x, y (m), yaw (rad): begin here, facing there
  std::vector<Eigen::Vector2d> waypoints;   // drive through these in order and end at the last
  std::optional<Eigen::Vector2d> landmark;  // begin 15-45 m (geodesic) away from this floor point, then pass it
  bool via_ramp = true;  // begin before a ramp where the floor has one; false: anywhere (streets in the open air)
  // Mapping: every free cell lies within this geodesic distance (m) of a waypoint. Indoors 4.5 m enters every room;
  // on open streets, seen far along, 10 m drives each street once.
  double coverage_radius = 4.5;
};

// Mapping: visits waypoints spread over the whole free region (every free cell within the request's
// coverage_radius of one), in a short order. Test: the request's waypoints, if any; else it passes the landmark
// (starting 15 to 45 m from it) or, where the floor has ramps and the request says via_ramp, starts a few metres before
// a ramp and drives over it; then on through random waypoints until it is at least min_length long. Different seeds
// give different routes. Requested points snap to the nearest free cell within 1 m (Error if none).
Route plan_route(const TraversabilityGrid& grid, const RayCaster& scene, const RobotModel& robot, RouteKind kind,
                 std::uint64_t seed, double min_length, const RouteRequest& request = {});

// Floor cells whose slope is at least min_slope_deg, grouped into connected ramps (each at least 0.2 m^2
// and rising at least 0.1 m).
std::vector<std::vector<int>> find_ramps(const TraversabilityGrid& grid, double min_slope_deg = 3.0);

}  // namespace tsdf_mcl::sim
