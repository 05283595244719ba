#include "message_codec.hpp"

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"
#include "tsdf_mcl/io/ros1_messages.hpp"
#include "tsdf_mcl/io/ros2_messages.hpp"

namespace tsdf_mcl::bag_io {
namespace {

TypeName of(const ros1::MessageType& t) { return {t.name, t.md5}; }

}  // namespace

std::vector<TypeName> type_names(MessageKind kind, WireFormat format) {
  const bool ros1 = format == WireFormat::ros1;
  switch (kind) {
    case MessageKind::pointcloud2:
      return {ros1 ? of(ros1::kPointCloud2) : TypeName{ros2::kPointCloud2, nullptr}};
    case MessageKind::tf:
      if (ros1) return {of(ros1::kTfMessage), of(ros1::kOldTfMessage)};
      return {{ros2::kTfMessage, nullptr}};
    case MessageKind::odometry:
      return {ros1 ? of(ros1::kOdometry) : TypeName{ros2::kOdometry, nullptr}};
    case MessageKind::pose_stamped:
      return {ros1 ? of(ros1::kPoseStamped) : TypeName{ros2::kPoseStamped, nullptr}};
    case MessageKind::pose_with_covariance_stamped:
      return {ros1 ? of(ros1::kPoseWithCovarianceStamped) : TypeName{ros2::kPoseWithCovarianceStamped, nullptr}};
    case MessageKind::imu:
      return {ros1 ? of(ros1::kImu) : TypeName{ros2::kImu, nullptr}};
  }
  return {};
}

std::optional<MessageKind> kind_of(const TopicInfo& topic) {
  for (MessageKind kind : {MessageKind::pointcloud2, MessageKind::tf, MessageKind::odometry, MessageKind::pose_stamped,
                           MessageKind::pose_with_covariance_stamped, MessageKind::imu}) {
    for (const TypeName& t : type_names(kind, topic.format)) {
      if (topic.type == t.name) return kind;
    }
  }
  return std::nullopt;
}

msg::Header decode_header(WireFormat format, const std::uint8_t* data, std::size_t size, const std::string& what) {
  return format == WireFormat::ros1 ? ros1::decode_header(data, size, what) : ros2::decode_header(data, size, what);
}

std::vector<msg::TransformStamped> decode_tf(WireFormat format, const std::uint8_t* data, std::size_t size,
                                             const std::string& what) {
  return format == WireFormat::ros1 ? ros1::decode_tf_message(data, size, what)
                                    : ros2::decode_tf_message(data, size, what);
}

msg::PoseMessage decode_pose(MessageKind kind, WireFormat format, const std::uint8_t* data, std::size_t size,
                             const std::string& what) {
  const bool ros1 = format == WireFormat::ros1;
  switch (kind) {
    case MessageKind::odometry:
      return ros1 ? ros1::decode_odometry(data, size, what) : ros2::decode_odometry(data, size, what);
    case MessageKind::pose_stamped:
      return ros1 ? ros1::decode_pose_stamped(data, size, what) : ros2::decode_pose_stamped(data, size, what);
    case MessageKind::pose_with_covariance_stamped:
      return ros1 ? ros1::decode_pose_with_covariance_stamped(data, size, what)
                  : ros2::decode_pose_with_covariance_stamped(data, size, what);
    default:
      throw Error(what + ": not a pose message");
  }
}

msg::Imu decode_imu(WireFormat format, const std::uint8_t* data, std::size_t size, const std::string& what) {
  return format == WireFormat::ros1 ? ros1::decode_imu(data, size, what) : ros2::decode_imu(data, size, what);
}

PointCloud decode_scan(WireFormat format, const std::uint8_t* data, std::size_t size, const std::string& what,
                       std::size_t* dropped_non_finite) {
  const msg::PointCloud2Message m = format == WireFormat::ros1 ? ros1::decode_pointcloud2_message(data, size, what)
                                                               : ros2::decode_pointcloud2_message(data, size, what);
  PointCloud2Stats stats;
  PointCloud cloud = decode_pointcloud2(m.layout, data + m.data_offset, m.data_size, &stats, what);
  if (stats.points == 0) throw Error(what + ": empty scan (a PointCloud2 of 0 points)");
  if (cloud.empty()) {
    throw Error(what + ": no finite points (" + std::to_string(stats.dropped_non_finite) + " NaN/Inf points dropped)");
  }
  if (dropped_non_finite) *dropped_non_finite = stats.dropped_non_finite;
  return cloud;
}

}  // namespace tsdf_mcl::bag_io
