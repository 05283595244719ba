#include "ros_conversions.hpp"

#include <algorithm>

#include "tsdf_mcl/io/ros_message_fields.hpp"

namespace tsdf_mcl::ros_node {

node::RawStamp raw_stamp(const ros::Time& t) { return {static_cast<std::int64_t>(t.sec), t.nsec}; }

node::Header header_of(const std_msgs::Header& h) { return {raw_stamp(h.stamp), h.frame_id}; }

node::RawPose raw_pose(const geometry_msgs::Pose& msg) {
  node::RawPose p;
  p.position = {msg.position.x, msg.position.y, msg.position.z};
  p.orientation = {msg.orientation.x, msg.orientation.y, msg.orientation.z, msg.orientation.w};
  return p;
}

node::RawPose raw_pose(const geometry_msgs::Transform& msg) {
  node::RawPose p;
  p.position = {msg.translation.x, msg.translation.y, msg.translation.z};
  p.orientation = {msg.rotation.x, msg.rotation.y, msg.rotation.z, msg.rotation.w};
  return p;
}

node::CloudMsg cloud_of(const sensor_msgs::PointCloud2ConstPtr& msg) {
  node::CloudMsg c;
  c.header = header_of(msg->header);
  c.layout.height = msg->height;
  c.layout.width = msg->width;
  c.layout.is_bigendian = msg->is_bigendian != 0;
  c.layout.point_step = msg->point_step;
  c.layout.row_step = msg->row_step;
  c.layout.is_dense = msg->is_dense != 0;
  for (const sensor_msgs::PointField& f : msg->fields)
    c.layout.fields.push_back({f.name, f.offset, f.datatype, f.count});
  c.data = msg->data.data();
  c.size = msg->data.size();
  // roscpp's boost pointer, held by the deleter of the core's std pointer.
  c.owner = std::shared_ptr<const void>(msg.get(), [msg](const void*) {});
  return c;
}

ros::Time ros_time(node::Stamp t) {
  constexpr std::int64_t kMax = 4294967295LL * 1000000000LL + 999999999LL;
  const std::int64_t ns = std::clamp<std::int64_t>(t.ns, 0, kMax);
  ros::Time out;
  out.sec = static_cast<std::uint32_t>(ns / 1000000000);
  out.nsec = static_cast<std::uint32_t>(ns % 1000000000);
  return out;
}

geometry_msgs::Pose msg_from_pose(const Pose& pose) {
  geometry_msgs::Pose msg;
  fill_pose_fields(pose, msg.position, msg.orientation);
  return msg;
}

geometry_msgs::Transform transform_from_pose(const Pose& pose) {
  geometry_msgs::Transform t;
  fill_pose_fields(pose, t.translation, t.rotation);
  return t;
}

geometry_msgs::PoseArray pose_array(const node::PosesOut& poses) {
  geometry_msgs::PoseArray msg;
  msg.header.stamp = ros_time(poses.stamp);
  msg.header.frame_id = poses.frame_id;
  for (const Pose& p : poses.poses) msg.poses.push_back(msg_from_pose(p));
  return msg;
}

sensor_msgs::PointCloud2 msg_from_cloud(const node::CloudOut& cloud) {
  sensor_msgs::PointCloud2 msg;
  msg.header.stamp = ros_time(cloud.stamp);
  msg.header.frame_id = cloud.frame_id;
  fill_pointcloud2_message(cloud.cloud, msg);
  return msg;
}

}  // namespace tsdf_mcl::ros_node
