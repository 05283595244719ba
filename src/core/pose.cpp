#include "tsdf_mcl/core/pose.hpp"

#include <algorithm>
#include <cmath>

namespace tsdf_mcl {

Pose pose_from_xyz_rpy(double x, double y, double z, double roll, double pitch, double yaw) {
  Pose pose = Pose::Identity();
  pose.linear() =
      (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
       Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  pose.translation() = Eigen::Vector3d(x, y, z);
  return pose;
}

Eigen::Vector3d rpy_of(const Eigen::Matrix3d& r) {
  const double pitch = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
  double roll;
  double yaw;
  if (std::abs(r(2, 0)) < 1.0 - 1e-9) {
    roll = std::atan2(r(2, 1), r(2, 2));
    yaw = std::atan2(r(1, 0), r(0, 0));
  } else {  // gimbal lock: only roll - yaw (or roll + yaw) is defined; put it all into yaw
    roll = 0.0;
    yaw = std::atan2(-r(0, 1), r(1, 1));
  }
  return {roll, pitch, yaw};
}

Pose pose_from_kitti(const std::array<double, 12>& v) {
  Pose pose = Pose::Identity();
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) pose.linear()(row, col) = v[row * 4 + col];
    pose.translation()(row) = v[row * 4 + 3];
  }
  return orthonormalized(pose);
}

std::array<double, 12> kitti_of(const Pose& pose) {
  std::array<double, 12> v{};
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 3; ++col) v[row * 4 + col] = pose.linear()(row, col);
    v[row * 4 + 3] = pose.translation()(row);
  }
  return v;
}

double rotation_angle_between(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a * b.transpose()).angle();
}

Pose orthonormalized(const Pose& pose) {
  Pose out = pose;
  out.linear() = Eigen::Quaterniond(pose.linear()).normalized().toRotationMatrix();
  return out;
}

bool is_rotation_matrix(const Eigen::Matrix3d& r, double tolerance) {
  return r.allFinite() && (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= tolerance &&
         std::abs(r.determinant() - 1.0) <= tolerance;
}

}  // namespace tsdf_mcl
