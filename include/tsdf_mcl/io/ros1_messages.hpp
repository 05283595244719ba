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

#include "tsdf_mcl/io/pointcloud2.hpp"
#include "tsdf_mcl/core/pose.hpp"

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
inline constexpr MessageType kImu{"sensor_msgs/Imu", "6a62c6daae103f4ff57a132d6f95cec2"};

struct Header {
  std::uint32_t seq = 0;
  std::uint32_t sec = 0, nsec = 0;
  std::string frame_id;
  double stamp() const { return static_cast<double>(sec) + static_cast<double>(nsec) / 1e9; }
};

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

// nav_msgs/Odometry (child_frame_id set) and geometry_msgs/PoseStamped (child_frame_id empty): the pose
// header.frame_id_T_child.
struct PoseMessage {
  Header header;
  std::string child_frame_id;
  Pose pose = Pose::Identity();
};

// sensor_msgs/Imu, the parts we use (orientation and covariances are skipped).
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

// Each throws Error("WHAT: ...") for a message that is truncated, has bytes left over, or holds a value out of
// range (a non-finite number, a quaternion that is not of unit length within 1e-2: zero quaternions included).
PointCloud2Message decode_pointcloud2_message(const std::uint8_t* data, std::size_t size, const std::string& what);
std::vector<TransformStamped> decode_tf_message(const std::uint8_t* data, std::size_t size, const std::string& what);
PoseMessage decode_odometry(const std::uint8_t* data, std::size_t size, const std::string& what);
PoseMessage decode_pose_stamped(const std::uint8_t* data, std::size_t size, const std::string& what);
Imu decode_imu(const std::uint8_t* data, std::size_t size, const std::string& what);

// Only the header, from the start of any message that begins with one (PointCloud2, Odometry, ...).
Header decode_header(const std::uint8_t* data, std::size_t size, const std::string& what);

// The serialized bytes of a PointCloud2 message (the bag writer uses roscpp; this serves tests and fuzz seeds).
std::vector<std::uint8_t> encode_pointcloud2_message(const Header& header, const PointCloud2Layout& layout,
                                                     const std::vector<std::uint8_t>& data);

}  // namespace tsdf_mcl::ros1
