#pragma once
// What real robots and bags send a localization node, driven through any transport (node_link.hpp): a missing
// extrinsic, messages out of order, stamps and poses that are none, an off-map or non-unit /initialpose, a cloud whose
// frame changes, a burst, odometry that stalls, a late IMU sample, time going back. Each step waits for the node's
// status on a scan, never a fixed time. The node must run with point topic, odometry and IMU topics, the CPU backend,
// a few thousand particles and sensor_extrinsics for the frame lidar_b: [0, 0, 0.5, 0, 0, 90deg].
#include <string>

#include "node_link.hpp"

namespace tsdf_mcl::node::test {

struct HostileOptions {
  std::string extrinsic_parameter;  // how the transport names sensor_extrinsics.lidar_b (~sensor_extrinsics/lidar_b)
  std::string odom_topic = "/odom";
  bool ros1_time = false;  // stamps are ROS 1's uint32 seconds (else ROS 2's int32, which may be negative)
};

// The steps in order; a failed ASSERT ends the scenario (the caller checks HasFatalFailure).
void run_hostile_scenario(NodeLink& link, const HostileOptions& options);

}  // namespace tsdf_mcl::node::test
