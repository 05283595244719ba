#pragma once
// The message types a bag dataset reads, by kind, in either wire format: their names (ROS 1's with MD5 sums,
// ROS 2's), and their decoders (ros1_messages.hpp, ros2_messages.hpp), which hand out the same structs
// (bag_messages.hpp). Everything past this file is one code path for ROS 1 and ROS 2 bags.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "message_store.hpp"
#include "tsdf_mcl/core/point_cloud.hpp"
#include "tsdf_mcl/io/bag_messages.hpp"

namespace tsdf_mcl::bag_io {

enum class MessageKind { pointcloud2, tf, odometry, pose_stamped, pose_with_covariance_stamped, imu };

struct TypeName {
  const char* name;
  const char* md5;  // ROS 1 only (nullptr for ROS 2)
};
// The type names a topic of `kind` carries in `format` (tf: tf2_msgs' and the older tf's).
std::vector<TypeName> type_names(MessageKind kind, WireFormat format);
// The kind of a topic's type; nullopt for a type not read here.
std::optional<MessageKind> kind_of(const TopicInfo& topic);

msg::Header decode_header(WireFormat format, const std::uint8_t* data, std::size_t size, const std::string& what);
std::vector<msg::TransformStamped> decode_tf(WireFormat format, const std::uint8_t* data, std::size_t size,
                                             const std::string& what);
// Odometry, PoseStamped or PoseWithCovarianceStamped (`kind`).
msg::PoseMessage decode_pose(MessageKind kind, WireFormat format, const std::uint8_t* data, std::size_t size,
                             const std::string& what);
msg::Imu decode_imu(WireFormat format, const std::uint8_t* data, std::size_t size, const std::string& what);

// A scan from its PointCloud2 message, by the policy of Dataset::load_scan: a cloud of no points, or of no finite
// point, is an Error naming `what`.
PointCloud decode_scan(WireFormat format, const std::uint8_t* data, std::size_t size, const std::string& what,
                       std::size_t* dropped_non_finite);

}  // namespace tsdf_mcl::bag_io
