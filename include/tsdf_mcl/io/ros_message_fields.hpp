#pragma once
// ROS message classes filled from the library's types: templates over the message class (ROS 1's, or any with the
// same field names), so that this layer needs no ROS headers. The bag writer and the ROS node fill their messages
// through these.
#include <Eigen/Geometry>
#include <type_traits>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"

namespace tsdf_mcl {

// A pose into a message's position (or translation: x, y, z) and orientation (or rotation: x, y, z, w) fields:
// geometry_msgs/Pose and geometry_msgs/Transform alike.
template <class Position, class Orientation>
void fill_pose_fields(const Pose& pose, Position& position, Orientation& orientation) {
  position.x = pose.translation().x();
  position.y = pose.translation().y();
  position.z = pose.translation().z();
  const Eigen::Quaterniond q(pose.linear());
  orientation.x = q.x();
  orientation.y = q.y();
  orientation.z = q.z();
  orientation.w = q.w();
}

// A sensor_msgs/PointCloud2 message filled from an encoded cloud; the header is the caller's.
template <class Message>
void fill_pointcloud2_message(const EncodedPointCloud2& encoded, Message& msg) {
  msg.height = encoded.layout.height;
  msg.width = encoded.layout.width;
  msg.fields.clear();
  for (const PointField& f : encoded.layout.fields) {
    typename std::decay_t<decltype(msg.fields)>::value_type field;
    field.name = f.name;
    field.offset = f.offset;
    field.datatype = f.datatype;
    field.count = f.count;
    msg.fields.push_back(field);
  }
  msg.is_bigendian = encoded.layout.is_bigendian;
  msg.point_step = encoded.layout.point_step;
  msg.row_step = encoded.layout.row_step;
  msg.data = encoded.data;
  msg.is_dense = encoded.layout.is_dense;
}

}  // namespace tsdf_mcl
