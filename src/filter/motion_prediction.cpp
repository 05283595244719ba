#include "tsdf_mcl/filter/motion_prediction.hpp"

namespace tsdf_mcl {

void MotionPrediction::reset() {
  has_update_ = false;
  last_odometry_.reset();
  velocity_delta_.reset();
}

Pose MotionPrediction::delta(double time, const std::optional<Pose>& odometry) const {
  if (!has_update_) return Pose::Identity();
  switch (type_) {
    case MotionModelType::kOdometry:
      return orthonormalized(last_odometry_->inverse() * *odometry);
    case MotionModelType::kConstantVelocity:
      if (velocity_delta_ && velocity_dt_ > 0.0)
        return scale_motion(*velocity_delta_, (time - last_time_) / velocity_dt_);
      return Pose::Identity();
    case MotionModelType::kDiffusion:
      break;
  }
  return Pose::Identity();
}

void MotionPrediction::observe_estimate(double time, const Pose& previous, const Pose& current, bool localized) {
  if (type_ != MotionModelType::kConstantVelocity) return;
  if (has_update_ && localized && time > last_time_) {
    velocity_delta_ = previous.inverse() * current;
    velocity_dt_ = time - last_time_;
  } else {
    velocity_delta_.reset();
  }
}

void MotionPrediction::finish_update(double time, const std::optional<Pose>& odometry) {
  has_update_ = true;
  last_time_ = time;
  if (odometry) last_odometry_ = *odometry;
}

}  // namespace tsdf_mcl
