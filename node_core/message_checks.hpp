#pragma once
// What makes a message unusable, for both nodes: each check returns why ("" when the message can be used), so that
// the core rejects, counts and names it in /diagnostics before tf or the filter sees it. The conversions that follow
// a passed check (to_stamp, to_pose) cannot fail.
#include <string>

#include "node_messages.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::node {

// A coordinate beyond this (m) is corrupt: no map spans 1000 km, and float points lose all precision there.
constexpr double kMaxCoordinate = 1e6;
// A pose farther than this (m) outside the map's box is not on the map (an operator's click, a stale file).
constexpr double kMapMargin = 1.0;

// Negative seconds (ROS 2's int32 allows them; rclcpp refuses them), nanoseconds of a second or more, or seconds
// beyond ROS 1's uint32 range. Stamps up to 2^32 s (year 2106) are usable: the core keeps time in 64-bit
// nanoseconds, so differences never overflow.
std::string stamp_problem(const RawStamp& stamp);
Stamp to_stamp(const RawStamp& stamp);

// A NaN or infinite value, a position beyond kMaxCoordinate, or a quaternion that is not of unit length within 1 %
// of its square (tf2's tolerance). The norm is taken without overflow, so (1e200, 1e200, 0, 1e200) is too long, not
// a rotation. An all-zero quaternion is no rotation where `zero_rotation_ok` (an odometry or initial pose message
// that filled in only the position), an error otherwise (tf2 refuses it too).
std::string pose_problem(const RawPose& pose, bool zero_rotation_ok);
Pose to_pose(const RawPose& pose);

// A specific force that is not finite or beyond 1000 m/s^2 (100 g: no IMU of a robot reads that).
std::string imu_problem(const ImuMsg& imu);

// A position outside the map's box grown by kMapMargin, naming the box.
std::string outside_map_problem(const TsdfMap& map, const Eigen::Vector3d& position);

}  // namespace tsdf_mcl::node
