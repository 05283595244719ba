#pragma once
// Between the ROS 2 message structs idlc generates (ros2/idl) and the node core's messages, field by field: every
// check is the core's. Outgoing messages are built in objects that own the strings and sequences the C structs point
// to, so a message is written without a copy into Cyclone's allocator.
#include <string>
#include <vector>

#include "dds_endpoints.hpp"
#include "diagnostic_msgs.h"
#include "geometry_msgs.h"
#include "nav2_msgs.h"
#include "nav_msgs.h"
#include "node_messages.hpp"
#include "rosgraph_msgs.h"
#include "sensor_msgs.h"
#include "tf2_msgs.h"

namespace tsdf_mcl::ros2_node {

node::RawStamp raw_stamp(const builtin_interfaces_msg_dds__Time_& t);
// ROS 2's int32 seconds: clamped to 0 .. 2^31 s (a stamp beyond it, a ROS 1 time, cannot be sent).
builtin_interfaces_msg_dds__Time_ ros2_time(node::Stamp t);
node::Header header_of(const std_msgs_msg_dds__Header_& h);
node::RawPose raw_pose(const geometry_msgs_msg_dds__Pose_& p);
node::RawPose raw_pose(const geometry_msgs_msg_dds__Transform_& t);
geometry_msgs_msg_dds__Pose_ pose_msg(const Pose& pose);

std::vector<node::TransformMsg> transforms_of(const tf2_msgs_msg_dds__TFMessage_& m);
node::OdometryMsg odometry_of(const nav_msgs_msg_dds__Odometry_& m);
node::ImuMsg imu_of(const sensor_msgs_msg_dds__Imu_& m);
node::InitialPoseMsg initial_pose_of(const geometry_msgs_msg_dds__PoseWithCovarianceStamped_& m);
// The cloud's layout and a view of its data, which `sample` (a PointCloud2_) keeps alive.
node::CloudMsg cloud_of(const Sample& sample);

// Outgoing messages: `msg` points into the object, which must outlive the write and cannot be copied.
struct Pinned {
  Pinned() = default;
  Pinned(const Pinned&) = delete;
  Pinned& operator=(const Pinned&) = delete;
};

struct PoseMessage : Pinned {
  explicit PoseMessage(const node::PoseOut& pose);
  std::string frame_id;
  geometry_msgs_msg_dds__PoseWithCovarianceStamped_ msg{};
};

struct ParticleCloudMessage : Pinned {  // nav2_msgs/ParticleCloud: the particle cloud and the ranked hypotheses
  explicit ParticleCloudMessage(const node::PosesOut& poses);
  std::string frame_id;
  std::vector<nav2_msgs_msg_dds__Particle_> particles;
  nav2_msgs_msg_dds__ParticleCloud_ msg{};
};

struct DiagnosticMessage : Pinned {
  explicit DiagnosticMessage(const node::DiagnosticOut& status);
  node::DiagnosticOut source;
  std::vector<diagnostic_msgs_msg_dds__KeyValue_> values;
  diagnostic_msgs_msg_dds__DiagnosticStatus_ status{};
  diagnostic_msgs_msg_dds__DiagnosticArray_ msg{};
};

struct TransformMessage : Pinned {  // tf2_msgs/TFMessage with one transform
  explicit TransformMessage(const node::TransformOut& transform);
  std::string parent, child;
  geometry_msgs_msg_dds__TransformStamped_ transform{};
  tf2_msgs_msg_dds__TFMessage_ msg{};
};

struct CloudMessage : Pinned {
  explicit CloudMessage(const node::CloudOut& cloud);
  node::CloudOut source;
  std::vector<sensor_msgs_msg_dds__PointField_> fields;
  sensor_msgs_msg_dds__PointCloud2_ msg{};
};

}  // namespace tsdf_mcl::ros2_node
