#include "ros_conversions.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "tsdf_mcl/io/pointcloud2.hpp"
#include "tsdf_mcl/io/ros_message_fields.hpp"

namespace tsdf_mcl::ros_node {

Pose pose_from_msg(const geometry_msgs::Pose& msg) {
  Eigen::Quaterniond q(msg.orientation.w, msg.orientation.x, msg.orientation.y, msg.orientation.z);
  // An all-zero quaternion (a message that left the orientation out) means no rotation.
  q = q.norm() > 1e-9 ? q.normalized() : Eigen::Quaterniond::Identity();
  Pose p = Pose::Identity();
  p.linear() = q.toRotationMatrix();
  p.translation() = Eigen::Vector3d(msg.position.x, msg.position.y, msg.position.z);
  return p;
}

geometry_msgs::Pose msg_from_pose(const Pose& pose) {
  geometry_msgs::Pose msg;
  fill_pose_fields(pose, msg.position, msg.orientation);
  return msg;
}

Pose pose_from_msg(const geometry_msgs::Transform& msg) {
  geometry_msgs::Pose p;
  p.position.x = msg.translation.x;
  p.position.y = msg.translation.y;
  p.position.z = msg.translation.z;
  p.orientation = msg.rotation;
  return pose_from_msg(p);
}

geometry_msgs::Transform transform_from_pose(const Pose& pose) {
  geometry_msgs::Transform t;
  fill_pose_fields(pose, t.translation, t.rotation);
  return t;
}

boost::array<double, 36> ros_covariance(const Pose& mean, const Matrix6d& body_covariance) {
  // A small rotation δ about the body axes is R·δ about the fixed axes: rotate the rotation rows and columns.
  Matrix6d j = Matrix6d::Identity();
  j.bottomRightCorner<3, 3>() = mean.rotation();
  const Matrix6d world = j * body_covariance * j.transpose();
  boost::array<double, 36> out{};
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) out[static_cast<std::size_t>(r * 6 + c)] = world(r, c);
  return out;
}

PointCloud cloud_from_msg(const sensor_msgs::PointCloud2& msg, const std::string& what,
                          std::size_t* dropped_non_finite) {
  PointCloud2Layout layout;
  layout.height = msg.height;
  layout.width = msg.width;
  layout.is_bigendian = msg.is_bigendian != 0;
  layout.point_step = msg.point_step;
  layout.row_step = msg.row_step;
  layout.is_dense = msg.is_dense != 0;
  for (const sensor_msgs::PointField& f : msg.fields) layout.fields.push_back({f.name, f.offset, f.datatype, f.count});
  PointCloud2Stats stats;
  PointCloud cloud = decode_pointcloud2(layout, msg.data.data(), msg.data.size(), &stats, what);
  if (dropped_non_finite) *dropped_non_finite = stats.dropped_non_finite;
  return cloud;
}

sensor_msgs::PointCloud2 msg_from_cloud(const PointCloud& cloud) {
  sensor_msgs::PointCloud2 msg;
  fill_pointcloud2_message(encode_pointcloud2(cloud), msg);
  return msg;
}

}  // namespace tsdf_mcl::ros_node
