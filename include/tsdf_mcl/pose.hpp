#pragma once
// Rigid poses and their conversions. Filter state is always a rotation (quaternion / matrix);
// Euler angles (roll, pitch, yaw; extrinsic X-Y-Z, i.e. R = Rz(yaw) Ry(pitch) Rx(roll)) exist only at the edges.
#include <Eigen/Geometry>
#include <array>

namespace tsdf_mcl {

using Pose = Eigen::Isometry3d;  // world_T_sensor unless a name says otherwise

// R = Rz(yaw) * Ry(pitch) * Rx(roll).
Pose pose_from_xyz_rpy(double x, double y, double z, double roll, double pitch, double yaw);
Eigen::Vector3d rpy_of(const Eigen::Matrix3d& rotation);  // inverse of the above; pitch in [-pi/2, pi/2]

// KITTI pose line: 12 numbers, 3x4 row-major [R | t].
Pose pose_from_kitti(const std::array<double, 12>& values);
std::array<double, 12> kitti_of(const Pose& pose);

// Rotation angle (rad) of a ∘ b⁻¹, in [0, pi].
double rotation_angle_between(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

// Re-orthonormalizes a pose's rotation (text files carry 6-9 digits).
Pose orthonormalized(const Pose& pose);

}  // namespace tsdf_mcl
