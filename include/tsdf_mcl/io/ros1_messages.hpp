#pragma once
// The ROS 1 messages a bag dataset reads, decoded from their serialized bytes (the ROS 1 wire format: little-endian,
// uint32 length before every string and variable-length array) without ROS headers.
//
// Why not roscpp_serialization: its array deserializer resizes the vector to the length field before checking it
// against the message, so a 100-byte message in a crafted bag can ask for 4 GiB. Here every length is checked
// against the bytes left before anything is allocated, every value is checked (finite numbers, unit quaternions),
// and the decoders build and are fuzzed where no ROS package is installed. The bag reader (src/io/rosbag/) hands
// them the bytes rosbag_storage reads; the tests check them against roscpp's own serialization.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "tsdf_mcl/io/bag_messages.hpp"

namespace tsdf_mcl::ros1 {

// Message types: name and MD5 sum of the definition, as a bag's connection records carry them.
struct MessageType {
  const char* name;
  const char* md5;
};
inline constexpr MessageType kPointCloud2{"sensor_msgs/PointCloud2", "1158d486dd51d683ce2f1be655c3c181"};
inline constexpr MessageType kTfMessage{"tf2_msgs/TFMessage", "94810edda583a504dfda3829e70d7eec"};
inline constexpr MessageType kOldTfMessage{"tf/tfMessage", "94810edda583a504dfda3829e70d7eec"};  // the same layout
inline constexpr MessageType kOdometry{"nav_msgs/Odometry", "cd5e73d190d741a2f92e81eda573aca7"};
inline constexpr MessageType kPoseStamped{"geometry_msgs/PoseStamped", "d3812c3cbc69362b77dc0b19b345f8f5"};
inline constexpr MessageType kPoseWithCovarianceStamped{"geometry_msgs/PoseWithCovarianceStamped",
                                                        "953b798c0f514ff060a53a3498ce6246"};
inline constexpr MessageType kImu{"sensor_msgs/Imu", "6a62c6daae103f4ff57a132d6f95cec2"};

// The decoded messages are those of every wire format (bag_messages.hpp).
using msg::Header;
using msg::Imu;
using msg::PointCloud2Message;
using msg::PoseMessage;
using msg::printable_name;
using msg::TransformStamped;

// Each throws Error("WHAT: ...") for a message that is truncated, has bytes left over, or holds a value out of
// range (a non-finite number, a quaternion that is not of unit length within 1e-2: zero quaternions included).
PointCloud2Message decode_pointcloud2_message(const std::uint8_t* data, std::size_t size, const std::string& what);
std::vector<TransformStamped> decode_tf_message(const std::uint8_t* data, std::size_t size, const std::string& what);
PoseMessage decode_odometry(const std::uint8_t* data, std::size_t size, const std::string& what);
PoseMessage decode_pose_stamped(const std::uint8_t* data, std::size_t size, const std::string& what);
PoseMessage decode_pose_with_covariance_stamped(const std::uint8_t* data, std::size_t size, const std::string& what);
Imu decode_imu(const std::uint8_t* data, std::size_t size, const std::string& what);

// Only the header, from the start of any message that begins with one (PointCloud2, Odometry, ...).
Header decode_header(const std::uint8_t* data, std::size_t size, const std::string& what);

// The serialized bytes of a PointCloud2 message (the bag writer uses roscpp; this serves tests and fuzz seeds).
std::vector<std::uint8_t> encode_pointcloud2_message(const Header& header, const PointCloud2Layout& layout,
                                                     const std::vector<std::uint8_t>& data);

}  // namespace tsdf_mcl::ros1
