#pragma once
// The motion model's state between filter updates: the motion since the last update, by the model (the odometry's
// relative pose; the last estimated velocity stretched over the time passed; none for diffusion), and the state
// each model needs for it (the odometry pose at the last update; the motion between the last two localized
// estimates). The filter asks it for the delta, moves the particles by it (motion_model.hpp) and reports back.
#include <optional>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"

namespace tsdf_mcl {

class MotionPrediction {
 public:
  explicit MotionPrediction(MotionModelType type) : type_(type) {}

  // A new belief (initialization): the next update is the first, with no motion before it.
  void reset();
  bool has_update() const { return has_update_; }
  // Seconds since the last update (0 before the first).
  double elapsed(double time) const { return has_update_ ? time - last_time_ : 0.0; }
  // The motion since the last update in the sensor frame of the earlier pose (identity before the first);
  // `odometry` (odom_T_sensor at `time`) is required by the odometry model.
  Pose delta(double time, const std::optional<Pose>& odometry) const;
  // The estimate of an update at `time` moved from `previous` to `current`; `localized`: both were compact enough
  // for that to be motion (a spread belief's estimate jumps). The constant-velocity model keeps it as its velocity.
  void observe_estimate(double time, const Pose& previous, const Pose& current, bool localized);
  // The update at `time` is done: its time and odometry are the reference of the next delta.
  void finish_update(double time, const std::optional<Pose>& odometry);

 private:
  MotionModelType type_;
  bool has_update_ = false;
  double last_time_ = 0.0;
  std::optional<Pose> last_odometry_;
  // Constant velocity: the estimated motion between the last two updates and its duration.
  std::optional<Pose> velocity_delta_;
  double velocity_dt_ = 0.0;
};

}  // namespace tsdf_mcl
