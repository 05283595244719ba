#include "message_checks.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>

#include "text_format.hpp"

namespace tsdf_mcl::node {
namespace {

constexpr std::int64_t kMaxRos1Seconds = 4294967295;  // uint32
// tf2's QUATERNION_NORMALIZATION_TOLERANCE, on the squared norm.
constexpr double kQuaternionTolerance = 0.01;

}  // namespace

std::string stamp_problem(const RawStamp& stamp) {
  if (stamp.sec < 0) return "negative stamp (" + std::to_string(stamp.sec) + " s)";
  if (stamp.nanosec >= 1000000000u) {
    return "stamp with " + std::to_string(stamp.nanosec) + " nanoseconds (a second or more)";
  }
  if (stamp.sec > kMaxRos1Seconds) return "stamp " + std::to_string(stamp.sec) + " s is beyond 2^32 s";
  return "";
}

Stamp to_stamp(const RawStamp& stamp) { return {stamp.sec * 1000000000 + static_cast<std::int64_t>(stamp.nanosec)}; }

std::string pose_problem(const RawPose& pose, bool zero_rotation_ok) {
  const Eigen::Vector3d& p = pose.position;
  const Eigen::Vector4d& q = pose.orientation;
  if (!p.allFinite() || !q.allFinite()) {
    return format("non-finite pose (%g, %g, %g; quaternion %g, %g, %g, %g)", p.x(), p.y(), p.z(), q.x(), q.y(), q.z(),
                  q.w());
  }
  if (p.cwiseAbs().maxCoeff() > kMaxCoordinate) {
    return format("position (%g, %g, %g) m beyond %g m", p.x(), p.y(), p.z(), kMaxCoordinate);
  }
  const double largest = q.cwiseAbs().maxCoeff();
  if (largest == 0.0) return zero_rotation_ok ? "" : "quaternion (0, 0, 0, 0) is no rotation";
  // The norm scaled by the largest component: no overflow for components near the double range.
  const double norm = largest * (q / largest).norm();
  if (!(std::abs(norm * norm - 1.0) <= kQuaternionTolerance)) {
    return format("quaternion (%g, %g, %g, %g) is not of unit length (norm %g)", q.x(), q.y(), q.z(), q.w(), norm);
  }
  return "";
}

Pose to_pose(const RawPose& pose) {
  const Eigen::Vector4d& v = pose.orientation;
  Eigen::Quaterniond q(v.w(), v.x(), v.y(), v.z());
  q = v.cwiseAbs().maxCoeff() > 0.0 ? q.normalized() : Eigen::Quaterniond::Identity();
  Pose out = Pose::Identity();
  out.linear() = q.toRotationMatrix();
  out.translation() = pose.position;
  return out;
}

std::string imu_problem(const ImuMsg& imu) {
  const Eigen::Vector3d& a = imu.linear_acceleration;
  if (a.allFinite() && a.norm() < 1000.0) return "";
  return format("linear_acceleration (%g, %g, %g) is not finite or beyond 1000 m/s^2", a.x(), a.y(), a.z());
}

std::string outside_map_problem(const TsdfMap& map, const Eigen::Vector3d& position) {
  const Eigen::Vector3d lo = map.world_min().cast<double>() - Eigen::Vector3d::Constant(kMapMargin);
  const Eigen::Vector3d hi = map.world_max().cast<double>() + Eigen::Vector3d::Constant(kMapMargin);
  if ((position.array() >= lo.array()).all() && (position.array() <= hi.array()).all()) return "";
  const Eigen::Vector3f a = map.world_min(), b = map.world_max();
  return format("position (%.2f, %.2f, %.2f) m lies outside the map (x %.1f..%.1f, y %.1f..%.1f, z %.1f..%.1f m)",
                position.x(), position.y(), position.z(), a.x(), b.x(), a.y(), b.y(), a.z(), b.z());
}

}  // namespace tsdf_mcl::node
