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

// A rotation read from a file: orthonormal (|R^T R - I| <= tolerance everywhere) with det R = +1 (within the
// tolerance). Zero matrices and mirrors are not, and orthonormalizing would silently turn them into some rotation.
inline constexpr double kRotationTolerance = 1e-3;
bool is_rotation_matrix(const Eigen::Matrix3d& r, double tolerance = kRotationTolerance);

}  // namespace tsdf_mcl
