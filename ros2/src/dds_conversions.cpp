#include "dds_conversions.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <limits>

namespace tsdf_mcl::ros2_node {
namespace {

char* text(const std::string& s) { return const_cast<char*>(s.c_str()); }
// A string field a sender may leave NULL (idlc's C strings): read as empty.
std::string text_of(const char* s) { return s ? s : ""; }

template <typename Sequence, typename Item>
Sequence sequence_over(std::vector<Item>& items) {
  Sequence s{};
  s._length = s._maximum = static_cast<std::uint32_t>(items.size());
  s._buffer = items.data();
  s._release = false;
  return s;
}

}  // namespace

node::RawStamp raw_stamp(const builtin_interfaces_msg_dds__Time_& t) { return {t.sec, t.nanosec}; }

builtin_interfaces_msg_dds__Time_ ros2_time(node::Stamp t) {
  constexpr std::int64_t kMax =
      static_cast<std::int64_t>(std::numeric_limits<std::int32_t>::max()) * 1000000000 + 999999999;
  const std::int64_t ns = std::clamp<std::int64_t>(t.ns, 0, kMax);
  return {static_cast<std::int32_t>(ns / 1000000000), static_cast<std::uint32_t>(ns % 1000000000)};
}

node::Header header_of(const std_msgs_msg_dds__Header_& h) { return {raw_stamp(h.stamp), text_of(h.frame_id)}; }

node::RawPose raw_pose(const geometry_msgs_msg_dds__Pose_& p) {
  node::RawPose r;
  r.position = {p.position.x, p.position.y, p.position.z};
  r.orientation = {p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w};
  return r;
}

node::RawPose raw_pose(const geometry_msgs_msg_dds__Transform_& t) {
  node::RawPose r;
  r.position = {t.translation.x, t.translation.y, t.translation.z};
  r.orientation = {t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w};
  return r;
}

geometry_msgs_msg_dds__Pose_ pose_msg(const Pose& pose) {
  const Eigen::Quaterniond q(pose.rotation());
  const Eigen::Vector3d t = pose.translation();
  return {{t.x(), t.y(), t.z()}, {q.x(), q.y(), q.z(), q.w()}};
}

std::vector<node::TransformMsg> transforms_of(const tf2_msgs_msg_dds__TFMessage_& m) {
  std::vector<node::TransformMsg> out;
  for (std::uint32_t i = 0; i < m.transforms._length; ++i) {
    const geometry_msgs_msg_dds__TransformStamped_& t = m.transforms._buffer[i];
    out.push_back({header_of(t.header), text_of(t.child_frame_id), raw_pose(t.transform)});
  }
  return out;
}

node::OdometryMsg odometry_of(const nav_msgs_msg_dds__Odometry_& m) {
  return {header_of(m.header), raw_pose(m.pose.pose)};
}

node::ImuMsg imu_of(const sensor_msgs_msg_dds__Imu_& m) {
  const geometry_msgs_msg_dds__Vector3_& a = m.linear_acceleration;
  return {header_of(m.header), {a.x, a.y, a.z}};
}

node::InitialPoseMsg initial_pose_of(const geometry_msgs_msg_dds__PoseWithCovarianceStamped_& m) {
  return {header_of(m.header), raw_pose(m.pose.pose)};
}

node::CloudMsg cloud_of(const Sample& sample) {
  const auto& m = *static_cast<const sensor_msgs_msg_dds__PointCloud2_*>(sample.get());
  node::CloudMsg c;
  c.header = header_of(m.header);
  c.layout.height = m.height;
  c.layout.width = m.width;
  c.layout.is_bigendian = m.is_bigendian;
  c.layout.point_step = m.point_step;
  c.layout.row_step = m.row_step;
  c.layout.is_dense = m.is_dense;
  for (std::uint32_t i = 0; i < m.fields._length; ++i) {
    const sensor_msgs_msg_dds__PointField_& f = m.fields._buffer[i];
    c.layout.fields.push_back({text_of(f.name), f.offset, f.datatype, f.count});
  }
  c.data = m.data._buffer;
  c.size = m.data._length;
  c.owner = sample;
  return c;
}

PoseMessage::PoseMessage(const node::PoseOut& pose) : frame_id(pose.frame_id) {
  msg.header.stamp = ros2_time(pose.stamp);
  msg.header.frame_id = text(frame_id);
  msg.pose.pose = pose_msg(pose.pose);
  std::copy(pose.covariance.begin(), pose.covariance.end(), msg.pose.covariance);
}

ParticleCloudMessage::ParticleCloudMessage(const node::PosesOut& poses) : frame_id(poses.frame_id) {
  for (std::size_t i = 0; i < poses.poses.size(); ++i) {
    particles.push_back({pose_msg(poses.poses[i]), i < poses.weights.size() ? poses.weights[i] : 0.0});
  }
  msg.header.stamp = ros2_time(poses.stamp);
  msg.header.frame_id = text(frame_id);
  msg.particles = sequence_over<dds_sequence_nav2_msgs_msg_dds__Particle_>(particles);
}

DiagnosticMessage::DiagnosticMessage(const node::DiagnosticOut& status_out) : source(status_out) {
  for (const auto& [key, value] : source.values) values.push_back({text(key), text(value)});
  status.level = source.level;
  status.name = text(source.name);
  status.message = text(source.message);
  status.hardware_id = text(source.hardware_id);
  status.values = sequence_over<dds_sequence_diagnostic_msgs_msg_dds__KeyValue_>(values);
  msg.header.stamp = ros2_time(source.stamp);
  msg.header.frame_id = const_cast<char*>("");
  msg.status._length = msg.status._maximum = 1;
  msg.status._buffer = &status;
  msg.status._release = false;
}

TransformMessage::TransformMessage(const node::TransformOut& t) : parent(t.parent), child(t.child) {
  transform.header.stamp = ros2_time(t.stamp);
  transform.header.frame_id = text(parent);
  transform.child_frame_id = text(child);
  const geometry_msgs_msg_dds__Pose_ p = pose_msg(t.pose);
  transform.transform.translation = {p.position.x, p.position.y, p.position.z};
  transform.transform.rotation = p.orientation;
  msg.transforms._length = msg.transforms._maximum = 1;
  msg.transforms._buffer = &transform;
  msg.transforms._release = false;
}

CloudMessage::CloudMessage(const node::CloudOut& cloud) : source(cloud) {
  const PointCloud2Layout& l = source.cloud.layout;
  for (const PointField& f : l.fields) fields.push_back({text(f.name), f.offset, f.datatype, f.count});
  msg.header.stamp = ros2_time(source.stamp);
  msg.header.frame_id = text(source.frame_id);
  msg.height = l.height;
  msg.width = l.width;
  msg.fields = sequence_over<dds_sequence_sensor_msgs_msg_dds__PointField_>(fields);
  msg.is_bigendian = l.is_bigendian;
  msg.point_step = l.point_step;
  msg.row_step = l.row_step;
  msg.data = sequence_over<dds_sequence_uint8>(source.cloud.data);
  msg.is_dense = l.is_dense;
}

}  // namespace tsdf_mcl::ros2_node
