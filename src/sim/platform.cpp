#include "tsdf_mcl/sim/platform.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "interpolate.hpp"
#include "tsdf_mcl/sim/random.hpp"

namespace tsdf_mcl::sim {

namespace {

using Eigen::Vector3d;

constexpr double kSampleStep = 0.01;  // s between precomputed sensor poses
constexpr double kGravity = 9.81;
constexpr double kDeg = M_PI / 180.0;

// A smooth random wander within +-amplitude: the mean of three slow sines with random frequencies and phases.
class SlowWander {
 public:
  SlowWander(double amplitude, Rng& rng) : amplitude_(amplitude) {
    for (auto& w : waves_) w = {2.0 * M_PI * rng.uniform(0.03, 0.2), rng.uniform(0.0, 2.0 * M_PI)};
  }
  double operator()(double t) const {
    double sum = 0.0;
    for (const auto& [omega, phase] : waves_) sum += std::sin(omega * t + phase);
    return amplitude_ * sum / static_cast<double>(waves_.size());
  }

 private:
  double amplitude_;
  std::array<std::pair<double, double>, 3> waves_;
};

double heading_of(const Pose& base) { return std::atan2(base.linear()(1, 0), base.linear()(0, 0)); }

double smoothstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

std::size_t sample_count(const Route& route) {
  return static_cast<std::size_t>(std::ceil(route.duration() / kSampleStep)) + 1;
}

// Moving minimum over +-radius samples, then moving mean over +-radius/2: the result never exceeds the
// input (each mean averages minima over windows that contain the sample), and it changes gently.
std::vector<double> eroded_and_smoothed(const std::vector<double>& v, std::size_t radius) {
  const std::size_t n = v.size();
  std::vector<double> low(n), out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i >= radius ? i - radius : 0, b = std::min(n - 1, i + radius);
    low[i] =
        *std::min_element(v.begin() + static_cast<std::ptrdiff_t>(a), v.begin() + static_cast<std::ptrdiff_t>(b) + 1);
  }
  const std::size_t half = radius / 2;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i >= half ? i - half : 0, b = std::min(n - 1, i + half);
    double sum = 0.0;
    for (std::size_t k = a; k <= b; ++k) sum += low[k];
    out[i] = sum / static_cast<double>(b - a + 1);
  }
  return out;
}

// Free height over the floor at the drone's position: rays up from inside the robot's clear band (1 m),
// through the centre and eight points on a 0.25 m circle; the open sky counts as the maximum.
double headroom(const RayCaster& scene, const Pose& base) {
  const Vector3d p = base.translation();
  const float start = 0.5f;
  float nearest = std::numeric_limits<float>::infinity();
  for (int k = 0; k < 9; ++k) {
    const double a = 2.0 * M_PI * k / 8.0, r = k == 8 ? 0.0 : 0.25;
    const Eigen::Vector3f origin(static_cast<float>(p.x() + r * std::cos(a)),
                                 static_cast<float>(p.y() + r * std::sin(a)), static_cast<float>(p.z()) + start);
    nearest = std::min(nearest, scene.cast(origin, Eigen::Vector3f::UnitZ(), 20.0f).distance);
  }
  return std::isinf(nearest) ? Flight::kMaxHeight + Flight::kHeadroom : start + nearest;
}

// The drone's height over the floor at each sample: a random profile between the minimum and maximum (a new
// height every 6 m flown, eased in between), kept kHeadroom below whatever is above, descending early.
std::vector<double> flight_heights(const Route& route, const RayCaster& scene, Rng& rng) {
  const std::size_t n = sample_count(route);
  constexpr double kKnotSpacing = 6.0;  // m
  std::vector<double> knots;
  for (double d = 0.0; d <= route.length() + kKnotSpacing; d += kKnotSpacing) {
    knots.push_back(rng.uniform(Flight::kMinHeight, Flight::kMaxHeight));
  }
  std::vector<double> target(n);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    const double t = static_cast<double>(i) * kSampleStep;
    const double d = route.distance_at(t) / kKnotSpacing;
    const auto k = static_cast<std::size_t>(d);
    const double eased = knots[k] + (knots[k + 1] - knots[k]) * smoothstep(d - static_cast<double>(k));
    target[static_cast<std::size_t>(i)] = std::min(eased, headroom(scene, route.base_pose(t)) - Flight::kHeadroom);
  }
  std::vector<double> heights = eroded_and_smoothed(target, static_cast<std::size_t>(1.5 / kSampleStep));
  for (double& h : heights) h = std::max(h, Flight::kLowest);
  return heights;
}

// The yaw offset from the path's heading: from time to time the drone turns to look sideways for a while
// (half the segments, up to kMaxYawOffsetDeg), easing over 2 s between segments of 4-10 s.
std::vector<double> yaw_offsets(std::size_t n, Rng& rng) {
  std::vector<double> offset(n, 0.0);
  double from = 0.0, segment_start = 0.0;
  std::size_t i = 0;
  while (i < n) {
    const double length = rng.uniform(4.0, 10.0);
    const double to = rng.chance(0.5) ? 0.0 : rng.uniform(-1.0, 1.0) * Flight::kMaxYawOffsetDeg * kDeg;
    for (; i < n && static_cast<double>(i) * kSampleStep < segment_start + length; ++i) {
      offset[i] = from + (to - from) * smoothstep((static_cast<double>(i) * kSampleStep - segment_start) / 2.0);
    }
    from = to;
    segment_start += length;
  }
  return offset;
}

// Point i of a sequence of at least two points, continued past its ends at their velocities: a truncated
// route ends at full speed, not with a sudden stop.
Vector3d extended(const std::vector<Vector3d>& p, std::ptrdiff_t i) {
  const auto n = static_cast<std::ptrdiff_t>(p.size());
  if (i < 0) return p[0] + static_cast<double>(i) * (p[1] - p[0]);
  if (i >= n) return p[n - 1] + static_cast<double>(i - n + 1) * (p[n - 1] - p[n - 2]);
  return p[static_cast<std::size_t>(i)];
}

// Gaussian smoothing (sigma in samples) of a sequence, continued past its ends.
std::vector<Vector3d> smoothed(const std::vector<Vector3d>& p, double sigma) {
  const auto reach = static_cast<std::ptrdiff_t>(std::ceil(3.0 * sigma));
  std::vector<double> kernel(static_cast<std::size_t>(2 * reach + 1));
  for (std::ptrdiff_t k = -reach; k <= reach; ++k) {
    kernel[static_cast<std::size_t>(k + reach)] = std::exp(-0.5 * static_cast<double>(k * k) / (sigma * sigma));
  }
  const auto n = static_cast<std::ptrdiff_t>(p.size());
  std::vector<Vector3d> out(p.size());
  for (std::ptrdiff_t i = 0; i < n; ++i) {
    Vector3d sum = Vector3d::Zero();
    double weight = 0.0;
    for (std::ptrdiff_t k = -reach; k <= reach; ++k) {
      const double w = kernel[static_cast<std::size_t>(k + reach)];
      sum += w * extended(p, i + k);
      weight += w;
    }
    out[static_cast<std::size_t>(i)] = sum / weight;
  }
  return out;
}

// The attitude whose thrust (body z) balances gravity and gives the acceleration a, tilted at most
// kMaxTiltDeg, turned to `yaw` about that thrust axis.
Eigen::Matrix3d attitude(const Vector3d& a, double yaw) {
  Vector3d thrust = a + Vector3d(0.0, 0.0, kGravity);
  const double max_tilt = Flight::kMaxTiltDeg * kDeg;
  const double horizontal = thrust.head<2>().norm();
  if (std::atan2(horizontal, thrust.z()) > max_tilt) {
    thrust.head<2>() *= std::tan(max_tilt) * thrust.z() / horizontal;
  }
  const Eigen::Quaterniond tilt = Eigen::Quaterniond::FromTwoVectors(Vector3d::UnitZ(), thrust.normalized());
  return tilt.toRotationMatrix() * Eigen::AngleAxisd(yaw, Vector3d::UnitZ()).toRotationMatrix();
}

}  // namespace

RobotModel RobotModel::of(Platform platform) {
  RobotModel robot;
  if (platform == Platform::handheld) {
    robot.sensor_height = 1.5;
    robot.speed = 1.2;
    robot.max_turn_rate = 1.5;
    robot.max_acceleration = 0.8;
  } else if (platform == Platform::drone) {
    robot.speed = 1.5;
    robot.max_turn_rate = 2.0;
    robot.max_acceleration = 2.5;
  }
  return robot;
}

SensorTrajectory::SensorTrajectory(const Route& route, const RayCaster& scene, Platform platform,
                                   const RobotModel& robot, double sensor_tilt_deg, std::uint64_t seed)
    : route_(route), platform_(platform), mount_(Pose::Identity()), odometry_frame_T_sensor_(Pose::Identity()) {
  mount_.linear() = Eigen::AngleAxisd(sensor_tilt_deg * kDeg, Vector3d::UnitY()).toRotationMatrix();
  switch (platform) {
    case Platform::ground:
      odometry_frame_T_sensor_ = mount_;
      odometry_frame_T_sensor_.translation().z() = robot.sensor_height;
      break;
    case Platform::handheld:
      walk(robot, seed);
      break;
    case Platform::drone:
      fly(scene, seed);
      break;
  }
}

void SensorTrajectory::walk(const RobotModel& robot, std::uint64_t seed) {
  Rng rng(seed);
  const SlowWander roll_drift(Gait::kDriftDeg * kDeg, rng), pitch_drift(Gait::kDriftDeg * kDeg, rng),
      yaw_drift(Gait::kDriftDeg * kDeg, rng);
  const double pitch_phase = rng.uniform(0.0, 2.0 * M_PI), yaw_phase = rng.uniform(0.0, 2.0 * M_PI);
  const std::size_t n = sample_count(route_);
  samples_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) * kSampleStep;
    const Pose base = route_.base_pose(t);
    // The gait follows the distance walked, so it pauses when the person stands; its size follows the speed.
    const double speed = (route_.distance_at(t + 0.1) - route_.distance_at(t - 0.1)) / 0.2;
    const double s = std::clamp(speed / robot.speed, 0.0, 1.0);
    const double step_phase = 2.0 * M_PI * route_.distance_at(t) / Gait::kStepLength;
    const double roll = s * Gait::kRollDeg * kDeg * std::sin(step_phase / 2.0) + roll_drift(t);
    const double pitch = s * Gait::kPitchDeg * kDeg * std::sin(step_phase + pitch_phase) + pitch_drift(t);
    const double yaw =
        heading_of(base) + s * Gait::kYawDeg * kDeg * std::sin(step_phase / 2.0 + yaw_phase) + yaw_drift(t);
    const Vector3d p = base.translation();
    const double z = p.z() + robot.sensor_height + s * Gait::kBob * std::cos(step_phase);
    samples_[i] = pose_from_xyz_rpy(p.x(), p.y(), z, roll, pitch, yaw) * mount_;
  }
}

void SensorTrajectory::fly(const RayCaster& scene, std::uint64_t seed) {
  Rng rng(seed);
  const std::size_t n = sample_count(route_);
  const std::vector<double> heights = flight_heights(route_, scene, rng);
  const std::vector<double> offsets = yaw_offsets(n, rng);
  std::vector<Vector3d> position(n);
  std::vector<double> heading(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Pose base = route_.base_pose(static_cast<double>(i) * kSampleStep);
    position[i] = base.translation() + Vector3d(0.0, 0.0, heights[i]);
    heading[i] = heading_of(base);
  }
  // The attitude follows the acceleration of the path smoothed over a quarter second (the drone's response).
  const std::vector<Vector3d> smooth = smoothed(position, 0.25 / kSampleStep);
  constexpr std::ptrdiff_t m = 5;  // samples either side of the second difference
  const double h2 = std::pow(static_cast<double>(m) * kSampleStep, 2);
  samples_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto k = static_cast<std::ptrdiff_t>(i);
    const Vector3d a = (extended(smooth, k + m) - 2.0 * smooth[i] + extended(smooth, k - m)) / h2;
    Pose pose = Pose::Identity();
    pose.linear() = attitude(a, heading[i] + offsets[i]);
    pose.translation() = position[i];
    samples_[i] = pose * mount_;
  }
}

Pose SensorTrajectory::sensor_pose(double time) const {
  if (platform_ == Platform::ground) return route_.base_pose(time) * odometry_frame_T_sensor_;
  const double at = std::clamp(time / kSampleStep, 0.0, static_cast<double>(samples_.size() - 1));
  const auto i = std::min(static_cast<std::size_t>(at), samples_.size() - 2);
  return interpolate(samples_[i], samples_[i + 1], at - static_cast<double>(i));
}

Pose SensorTrajectory::odometry_frame_pose(double time) const {
  return platform_ == Platform::ground ? route_.base_pose(time) : sensor_pose(time);
}

Pose SensorTrajectory::first_odometry_pose(double time) const {
  if (platform_ == Platform::ground) return Pose::Identity();
  return orthonormalized(route_.base_pose(time).inverse() * sensor_pose(time));
}

}  // namespace tsdf_mcl::sim
