#pragma once
// The ROS 2 messages a bag dataset reads, decoded from CDR (cdr.hpp) without ROS 2 headers, and encoded for the
// rosbag2 writer (simulate --bag FILE.mcap) and tests. The layouts are those of ros2/common_interfaces and
// ros2/rcl_interfaces (humble to jazzy alike): std_msgs/Header is (builtin_interfaces/Time stamp: int32 sec, uint32
// nanosec; string frame_id), with no seq.
//
// The decoders check as ros1_messages.hpp's do: every length against the bytes left before anything is allocated,
// finite numbers, unit quaternions; both byte orders.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "tsdf_mcl/io/bag_messages.hpp"

namespace tsdf_mcl::ros2 {

// Type names as rosbag2 records them (the SQLite3 topics table, MCAP schema names).
inline constexpr const char* kPointCloud2 = "sensor_msgs/msg/PointCloud2";
inline constexpr const char* kTfMessage = "tf2_msgs/msg/TFMessage";
inline constexpr const char* kOdometry = "nav_msgs/msg/Odometry";
inline constexpr const char* kPoseStamped = "geometry_msgs/msg/PoseStamped";
inline constexpr const char* kPoseWithCovarianceStamped = "geometry_msgs/msg/PoseWithCovarianceStamped";
inline constexpr const char* kImu = "sensor_msgs/msg/Imu";

// The type's complete definition in the ros2msg encoding (its .msg text, then each type it uses after a line of 80
// '=' and "MSG: package/Type"), as MCAP schemas and rosbag2's message_definitions table hold it. Throws Error for a
// type other than the six above.
std::string message_definition(const std::string& type);

using msg::Header;
using msg::Imu;
using msg::PointCloud2Message;
using msg::PoseMessage;
using msg::TransformStamped;

// Each throws Error("WHAT: ...") for a message that is truncated, not plain CDR, has more than CDR's 3 bytes of
// padding left over, or holds a value out of range. PointCloud2Message's data offset counts from the message's first
// byte (the CDR header included).
PointCloud2Message decode_pointcloud2_message(const std::uint8_t* data, std::size_t size, const std::string& what);
std::vector<TransformStamped> decode_tf_message(const std::uint8_t* data, std::size_t size, const std::string& what);
PoseMessage decode_odometry(const std::uint8_t* data, std::size_t size, const std::string& what);
PoseMessage decode_pose_stamped(const std::uint8_t* data, std::size_t size, const std::string& what);
PoseMessage decode_pose_with_covariance_stamped(const std::uint8_t* data, std::size_t size, const std::string& what);
Imu decode_imu(const std::uint8_t* data, std::size_t size, const std::string& what);
// Only the header, from the start of any message that begins with one.
Header decode_header(const std::uint8_t* data, std::size_t size, const std::string& what);

// Encoders, little-endian (CDR_LE, as rmw writes) unless big_endian. Covariances and twists are written as zeros;
// the IMU's orientation as unknown (orientation_covariance[0] = -1, REP 145). Header.seq is not part of ROS 2.
std::vector<std::uint8_t> encode_pointcloud2_message(const Header& header, const PointCloud2Layout& layout,
                                                     const std::vector<std::uint8_t>& data, bool big_endian = false);
std::vector<std::uint8_t> encode_tf_message(const std::vector<TransformStamped>& transforms, bool big_endian = false);
std::vector<std::uint8_t> encode_odometry(const PoseMessage& odometry, bool big_endian = false);
std::vector<std::uint8_t> encode_pose_stamped(const PoseMessage& pose, bool big_endian = false);
std::vector<std::uint8_t> encode_pose_with_covariance_stamped(const PoseMessage& pose, bool big_endian = false);
std::vector<std::uint8_t> encode_imu(const Imu& imu, bool big_endian = false);

}  // namespace tsdf_mcl::ros2
