#pragma once
// The sensor's true pose over a run: the route's base pose carried by a platform (ground robot, walking
// person, drone; see Platform in tsdf_mcl/sim/simulator.hpp), then the LiDAR's mounting tilt.
#include <cstdint>
#include <vector>

#include "tsdf_mcl/sim/route.hpp"
#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

// Handheld: a walking person's gait moves the sensor once per step (0.65 m) and once per stride (two
// steps), in proportion to the walking speed; holding it by hand adds slow drifts.
struct Gait {
  static constexpr double kStepLength = 0.65;  // m: 1.85 steps/s at 1.2 m/s
  static constexpr double kBob = 0.025;        // m up and down, once per step
  static constexpr double kRollDeg = 2.5;      // side to side, once per stride
  static constexpr double kPitchDeg = 1.5;     // once per step
  static constexpr double kYawDeg = 2.0;       // once per stride
  static constexpr double kDriftDeg = 1.5;     // slow wandering of roll, pitch and yaw (0.03-0.2 Hz)
};

// Drone: flight height above the floor, attitude from the acceleration, yaw excursions.
struct Flight {
  static constexpr double kMinHeight = 1.0;  // m; the route's height profile stays within these...
  static constexpr double kMaxHeight = 2.5;
  static constexpr double kLowest = 0.5;     // ...unless the headroom asks for less (never below this)
  static constexpr double kHeadroom = 0.35;  // m the sensor keeps below anything over the drone
  static constexpr double kMaxTiltDeg = 20.0;
  static constexpr double kMaxYawOffsetDeg = 90.0;  // looking away from the path
};

class SensorTrajectory {
 public:
  // seed: the platform's random stream (gait phases and drifts, flight heights, yaw excursions).
  SensorTrajectory(const Route& route, const RayCaster& scene, Platform platform, const RobotModel& robot,
                   double sensor_tilt_deg, std::uint64_t seed);

  Pose sensor_pose(double time) const;  // world_T_sensor, interpolated; clamped to the route's ends

  // Odometry measures the motion of one frame: the base (wheel odometry) on the ground robot, the sensor
  // itself (LiDAR-inertial odometry) on the others. The odom frame is the base's pose at the first sweep.
  Pose odometry_frame_pose(double time) const;
  const Pose& odometry_frame_T_sensor() const { return odometry_frame_T_sensor_; }
  Pose first_odometry_pose(double time) const;  // odom_T_(odometry frame) at the first sweep's time

 private:
  void walk(const RobotModel& robot, std::uint64_t seed);
  void fly(const RayCaster& scene, std::uint64_t seed);

  const Route& route_;
  Platform platform_;
  Pose mount_;                    // the mounting tilt
  Pose odometry_frame_T_sensor_;  // ground: base_T_sensor; others: identity
  std::vector<Pose> samples_;     // handheld and drone: world_T_sensor every kSampleStep s from 0
};

}  // namespace tsdf_mcl::sim
