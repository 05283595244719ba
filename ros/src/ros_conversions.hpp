#pragma once
// Between ROS 1 messages and the node core's (node_core/node_messages.hpp), field by field: every check is the
// core's. Kept apart from the node so that the conversions are plain functions with tests of their own.
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/Transform.h>
#include <ros/time.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>

#include "node_messages.hpp"
#include "tsdf_mcl/core/pose.hpp"

namespace tsdf_mcl::ros_node {

node::RawStamp raw_stamp(const ros::Time& t);
node::Header header_of(const std_msgs::Header& h);
node::RawPose raw_pose(const geometry_msgs::Pose& msg);
node::RawPose raw_pose(const geometry_msgs::Transform& msg);
// The cloud's layout and a view of its data, which `msg` keeps alive.
node::CloudMsg cloud_of(const sensor_msgs::PointCloud2ConstPtr& msg);

// A core stamp as ROS 1 time: clamped to 0 .. 2^32 s - 1 ns, ROS 1's range (a map -> odom stamp, a scan's plus
// transform_tolerance, may pass its end).
ros::Time ros_time(node::Stamp t);
geometry_msgs::Pose msg_from_pose(const Pose& pose);
geometry_msgs::Transform transform_from_pose(const Pose& pose);
geometry_msgs::PoseArray pose_array(const node::PosesOut& poses);
sensor_msgs::PointCloud2 msg_from_cloud(const node::CloudOut& cloud);

}  // namespace tsdf_mcl::ros_node
