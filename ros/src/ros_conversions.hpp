#pragma once
// Between ROS messages and the library's types. Kept apart from the node so that the conversions are plain
// functions with tests of their own.
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <sensor_msgs/PointCloud2.h>

#include <boost/array.hpp>
#include <string>

#include "tsdf_mcl/core/point_cloud.hpp"
#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/filter/pose_estimate.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::ros_node {

Pose pose_from_msg(const geometry_msgs::Pose& msg);
geometry_msgs::Pose msg_from_pose(const Pose& pose);
Pose pose_from_msg(const geometry_msgs::Transform& msg);
geometry_msgs::Transform transform_from_pose(const Pose& pose);

// The library's covariance (x, y, z, then the rotation vector in the body frame at the mean) as ROS wants it
// (x, y, z, rotation about the fixed X, Y, Z axes), row-major 6 x 6.
boost::array<double, 36> ros_covariance(const Pose& mean, const Matrix6d& body_covariance);

// A PointCloud2 through the library's checked decoder (any common layout; non-finite points dropped and
// counted). Throws Error naming `what`.
PointCloud cloud_from_msg(const sensor_msgs::PointCloud2& msg, const std::string& what,
                          std::size_t* dropped_non_finite = nullptr);
sensor_msgs::PointCloud2 msg_from_cloud(const PointCloud& cloud);

}  // namespace tsdf_mcl::ros_node
