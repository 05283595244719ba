#pragma once
// The messages a bag dataset reads, as their decoders hand them out whichever wire format they came in: ROS 1's
// (ros1_messages.hpp) or ROS 2's CDR (ros2_messages.hpp). Everything after decoding (the tf tree, odometry, ground
// truth, IMU, the scans: docs/bags.md) sees these alone, so ROS 1 and ROS 2 bags take one code path.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"

namespace tsdf_mcl::msg {

// std_msgs/Header. ROS 1 stamps are (uint32 sec, uint32 nsec) and carry a seq; ROS 2's builtin_interfaces/Time is
// (int32 sec, uint32 nanosec) and has no seq.
struct Header {
  std::uint32_t seq = 0;  // ROS 1 only
  std::int64_t sec = 0;
  std::uint32_t nsec = 0;
  std::string frame_id;
  double stamp() const { return static_cast<double>(sec) + static_cast<double>(nsec) / 1e9; }
};

// A time in seconds as (sec, nsec), rounded to the nearest nanosecond as ros::Time(double) does, so that a run
// written as a ROS 1 and as a ROS 2 bag reads back to the same stamps.
Header stamp_of(double seconds);

// sensor_msgs/PointCloud2; the data stay in the message's bytes: [data_offset, data_offset + data_size).
struct PointCloud2Message {
  Header header;
  PointCloud2Layout layout;
  std::size_t data_offset = 0, data_size = 0;
};

// geometry_msgs/TransformStamped: header.frame_id is the parent, the transform parent_T_child.
struct TransformStamped {
  Header header;
  std::string child_frame_id;
  Pose transform = Pose::Identity();
};

// nav_msgs/Odometry (child_frame_id set), geometry_msgs/PoseStamped and PoseWithCovarianceStamped (child_frame_id
// empty): the pose header.frame_id_T_child.
struct PoseMessage {
  Header header;
  std::string child_frame_id;
  Pose pose = Pose::Identity();
};

// sensor_msgs/Imu, the parts we use (orientation and covariances are skipped; writers mark the orientation unknown).
struct Imu {
  Header header;
  Eigen::Vector3d angular_velocity = Eigen::Vector3d::Zero();     // rad/s
  Eigen::Vector3d linear_acceleration = Eigen::Vector3d::Zero();  // m/s^2, specific force
};

// A name from a bag (topic, type, frame) as error messages show it: bytes outside printable ASCII become '?', at
// most 200 of them (a corrupt bag's names are arbitrary bytes).
inline std::string printable_name(const std::string& name) {
  std::string out = name.substr(0, 200);
  for (char& c : out) {
    if (c < 0x20 || c > 0x7E) c = '?';
  }
  return name.size() > 200 ? out + "..." : out;
}
// The same in single quotes: how errors name frames.
inline std::string quoted_name(const std::string& name) { return "'" + printable_name(name) + "'"; }

// Values as decoders check them, each throwing Error("WHAT: ITEM ...") naming the message and the field: a number
// that is not finite; a quaternion (x, y, z, w) not of unit length within 1e-2 (zero quaternions, the "unknown" of
// many drivers, included), else normalized.
double finite(double value, const std::string& what, const char* item);
Eigen::Quaterniond unit_quaternion(double x, double y, double z, double w, const std::string& what, const char* item);
Pose pose_of(const Eigen::Vector3d& translation, const Eigen::Quaterniond& rotation);

}  // namespace tsdf_mcl::msg
