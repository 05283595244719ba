#pragma once
// The motion update: every particle moves by the relative motion between two filter updates, plus noise that
// grows with that motion.
//
// nav2's odometry model, extended to 6-DoF. For a relative motion of translation d (m) and rotation angle
// theta (rad), both in the sensor frame of the earlier pose, the noise standard deviations are
//   yaw (about sensor z)         alpha1 * theta + alpha2 * d
//   translation along the motion alpha3 * d + alpha4 * theta
//   translation across it        alpha5 * d + alpha4 * theta     (horizontal in the sensor frame; nav2's
//                                                                 omni "strafe" term)
//   translation along sensor z   alpha6 * d + alpha4 * theta
//   roll and pitch               alpha7 * theta + alpha8 * d
// plus, for the constant-velocity and diffusion models, a random walk that grows with the square root of
// the elapsed time. z, roll and pitch have their own terms so a planar robot's defaults never freeze them: a
// particle whose height or tilt cannot move cannot correct an initial error in it.
#include <Eigen/Geometry>
#include <cstdint>
#include <string>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

enum class MotionModelType {
  kOdometry,          // relative motion between the odometry poses of two updates (needs odom.txt)
  kConstantVelocity,  // the last estimated motion, scaled to the elapsed time
  kDiffusion,         // no motion, only the random walk
};
MotionModelType parse_motion_model(const std::string& name);  // "odometry" | "constant_velocity" | "diffusion"
std::string to_string(MotionModelType type);

struct MotionParameters {
  MotionModelType type = MotionModelType::kOdometry;
  // Defaults cover wheel odometry with 10 % noise and 0.2 rad/m heading slip (the simulator's model) as well
  // as LiDAR odometry with 2 % drift (balm_realworld): larger values cost particles, smaller ones lose the
  // track where the odometry is worse than assumed.
  double alpha1 = 0.08;  // yaw noise from rotation (rad/rad)
  double alpha2 = 0.03;  // yaw noise from translation (rad/m)
  double alpha3 = 0.1;   // along-track translation noise from translation (m/m)
  double alpha4 = 0.05;  // translation noise from rotation (m/rad)
  double alpha5 = 0.08;  // cross-track translation noise from translation (m/m)
  double alpha6 = 0.08;  // vertical (sensor z) translation noise from translation (m/m)
  double alpha7 = 0.04;  // roll/pitch noise from rotation (rad/rad)
  double alpha8 = 0.02;  // roll/pitch noise from translation (rad/m)
  // The relative rotation comes from an IMU and is trusted: rotation noise is imu_sigma (rad per update,
  // each axis) instead of the alpha1/2/7/8 terms.
  bool imu_rotation = false;
  double imu_sigma = 0.005;
  // Random walk of the constant-velocity and diffusion models, per sqrt(second).
  double diffusion_xy = 0.2;           // m
  double diffusion_z = 0.05;           // m
  double diffusion_yaw = 0.1;          // rad
  double diffusion_roll_pitch = 0.03;  // rad

  void validate() const;  // throws Error naming the parameter
};

// Standard deviations of one motion step, in the sensor frame of the earlier pose.
struct MotionNoise {
  Eigen::Vector3f along = Eigen::Vector3f::UnitX();  // unit direction of the motion (sensor x if none)
  Eigen::Vector3f across = Eigen::Vector3f::UnitY();
  Eigen::Vector3f vertical = Eigen::Vector3f::UnitZ();
  float sigma_along = 0.0f;
  float sigma_across = 0.0f;
  float sigma_vertical = 0.0f;
  float sigma_roll = 0.0f;
  float sigma_pitch = 0.0f;
  float sigma_yaw = 0.0f;
};

// Noise of a relative motion `delta` over `dt` seconds under `params` (random walk only for the
// constant-velocity and diffusion models).
MotionNoise motion_noise(const MotionParameters& params, const Pose& delta, double dt);

// Below this many particles the per-particle loops run on the calling thread.
inline constexpr std::size_t kParallelParticles = 8192;

// particle <- particle * (delta with noise), for particles 0..n-1, in place. Each particle draws from its own
// stream Rng(seed, step, i), so the result does not depend on the thread count.
void apply_motion(const ParticleArrays& particles, std::size_t n, const Pose& delta, const MotionNoise& noise,
                  std::uint64_t seed, std::uint64_t step);

// `delta` with its rotation angle and translation scaled by s (s may exceed 1): the last motion stretched
// over a different time step.
Pose scale_motion(const Pose& delta, double s);

// exp of a rotation vector as a unit quaternion.
Eigen::Quaternionf quaternion_exp(const Eigen::Vector3f& rotation_vector);
Eigen::Vector3d quaternion_log(const Eigen::Quaterniond& q);  // rotation vector, angle in [0, pi]

}  // namespace tsdf_mcl
