#include "tsdf_mcl/filter/motion_model.hpp"

#include <cmath>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/random.hpp"

namespace tsdf_mcl {

MotionModelType parse_motion_model(const std::string& name) {
  if (name == "odometry") return MotionModelType::kOdometry;
  if (name == "constant_velocity") return MotionModelType::kConstantVelocity;
  if (name == "diffusion") return MotionModelType::kDiffusion;
  throw Error("unknown motion_model '" + name + "' (odometry, constant_velocity or diffusion)");
}

std::string to_string(MotionModelType type) {
  switch (type) {
    case MotionModelType::kOdometry:
      return "odometry";
    case MotionModelType::kConstantVelocity:
      return "constant_velocity";
    case MotionModelType::kDiffusion:
      return "diffusion";
  }
  return "?";
}

void MotionParameters::validate() const {
  const std::pair<const char*, double> values[] = {{"alpha1", alpha1},
                                                   {"alpha2", alpha2},
                                                   {"alpha3", alpha3},
                                                   {"alpha4", alpha4},
                                                   {"alpha5", alpha5},
                                                   {"alpha6", alpha6},
                                                   {"alpha7", alpha7},
                                                   {"alpha8", alpha8},
                                                   {"imu_sigma", imu_sigma},
                                                   {"diffusion_xy", diffusion_xy},
                                                   {"diffusion_z", diffusion_z},
                                                   {"diffusion_yaw", diffusion_yaw},
                                                   {"diffusion_roll_pitch", diffusion_roll_pitch}};
  for (const auto& [name, v] : values) {
    if (!(v >= 0.0) || !std::isfinite(v)) throw Error(std::string(name) + " must be a non-negative number");
  }
}

Eigen::Quaternionf quaternion_exp(const Eigen::Vector3f& v) {
  const float angle = v.norm();
  if (angle < 1e-8f) return Eigen::Quaternionf(1.0f, 0.5f * v.x(), 0.5f * v.y(), 0.5f * v.z()).normalized();
  const float s = std::sin(0.5f * angle) / angle;
  return Eigen::Quaternionf(std::cos(0.5f * angle), s * v.x(), s * v.y(), s * v.z());
}

Eigen::Vector3d quaternion_log(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // the short way round: angle in [0, pi]
  const double s = q.vec().norm();
  if (s < 1e-12) return 2.0 * q.vec();
  return q.vec() * (2.0 * std::atan2(s, q.w()) / s);
}

Pose scale_motion(const Pose& delta, double s) {
  Pose out = Pose::Identity();
  const Eigen::AngleAxisd aa(delta.linear());
  out.linear() = Eigen::AngleAxisd(aa.angle() * s, aa.axis()).toRotationMatrix();
  out.translation() = delta.translation() * s;
  return out;
}

MotionNoise motion_noise(const MotionParameters& p, const Pose& delta, double dt) {
  MotionNoise n;
  const Eigen::Vector3d t = delta.translation();
  const double d = t.norm();
  const double theta = Eigen::AngleAxisd(delta.linear()).angle();
  // Along = the motion's direction within the sensor's xy plane, so "across" stays horizontal in that frame.
  const Eigen::Vector2d planar(t.x(), t.y());
  if (planar.norm() > 1e-6) {
    n.along =
        Eigen::Vector3f(static_cast<float>(t.x() / planar.norm()), static_cast<float>(t.y() / planar.norm()), 0.0f);
    n.across = Eigen::Vector3f(-n.along.y(), n.along.x(), 0.0f);
  }
  double along = p.alpha3 * d + p.alpha4 * theta;
  double across = p.alpha5 * d + p.alpha4 * theta;
  double vertical = p.alpha6 * d + p.alpha4 * theta;
  double yaw = p.alpha1 * theta + p.alpha2 * d;
  double tilt = p.alpha7 * theta + p.alpha8 * d;
  if (p.imu_rotation) yaw = tilt = p.imu_sigma;
  if (p.type != MotionModelType::kOdometry) {
    // Independent noise sources add in variance.
    const double r = std::sqrt(std::max(dt, 0.0));
    auto add = [](double a, double b) { return std::sqrt(a * a + b * b); };
    along = add(along, p.diffusion_xy * r);
    across = add(across, p.diffusion_xy * r);
    vertical = add(vertical, p.diffusion_z * r);
    yaw = add(yaw, p.diffusion_yaw * r);
    tilt = add(tilt, p.diffusion_roll_pitch * r);
  }
  n.sigma_along = static_cast<float>(along);
  n.sigma_across = static_cast<float>(across);
  n.sigma_vertical = static_cast<float>(vertical);
  n.sigma_yaw = static_cast<float>(yaw);
  n.sigma_roll = n.sigma_pitch = static_cast<float>(tilt);
  return n;
}

void apply_motion(const ParticleArrays& p, std::size_t n, const Pose& delta, const MotionNoise& noise,
                  std::uint64_t seed, std::uint64_t step) {
  const Eigen::Vector3f dt = delta.translation().cast<float>();
  const Eigen::Quaternionf dq(Eigen::Quaterniond(delta.linear()).cast<float>());
  // Small (converged) sets are done before a thread team would even wake up.
#pragma omp parallel for schedule(static) if (n >= kParallelParticles)
  for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(n); ++k) {
    const auto i = static_cast<std::size_t>(k);
    Rng rng(seed, 0x40710Aull, step, i);
    const auto g = [&rng] { return static_cast<float>(rng.normal()); };
    const Eigen::Vector3f t = dt + noise.along * (noise.sigma_along * g()) + noise.across * (noise.sigma_across * g()) +
                              noise.vertical * (noise.sigma_vertical * g());
    const Eigen::Vector3f w(noise.sigma_roll * g(), noise.sigma_pitch * g(), noise.sigma_yaw * g());
    const Eigen::Quaternionf q = p.rotation(i);
    const Eigen::Vector3f pos = p.position(i) + q * t;
    p.set(i, pos, (q * dq * quaternion_exp(w)).normalized());
  }
}

}  // namespace tsdf_mcl
