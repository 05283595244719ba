#pragma once
// The ROS 1 node: roscpp's transport for the node core (node_core/localization_core.hpp), which holds everything
// else (the checks, tf, the filter, what is published when). This file subscribes and publishes with the names ROS 1
// amcl users expect and reads the parameters from the private namespace.
//
// In:  PointCloud2 on `point_topics`, /tf and /tf_static (on a thread of their own: lookups wait for tf while the
//      other callbacks run), nav_msgs/Odometry on `odom_topic`, sensor_msgs/Imu on `imu_topic`, /initialpose,
//      services global_localization and request_nomotion_update (std_srvs/Empty).
// Out: amcl_pose (latched), particlecloud (PoseArray), ~hypotheses (PoseArray, best first), tf map -> odom,
//      ~map_cloud (latched), /diagnostics.
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>

#include <memory>
#include <string>
#include <vector>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_srvs/Empty.h>
#include <tf2_msgs/TFMessage.h>

#include "localization_core.hpp"
#include "node_output.hpp"
#include "node_parameters.hpp"

namespace tsdf_mcl::ros_node {

// The private namespace's parameters by dotted name (~initial_pose/x is initial_pose.x).
node::NodeParameters private_parameters(const ros::NodeHandle& pnh);

class Ros1Node : public node::NodeOutput {
 public:
  // Reads the parameters, starts the core (which loads the map), advertises and subscribes. Throws Error for bad
  // parameters or map.
  Ros1Node(ros::NodeHandle nh, ros::NodeHandle pnh);
  ~Ros1Node() override;
  // Processes scans until ROS shuts down.
  void run();

  void publish_pose(const node::PoseOut& pose) override;
  bool particles_wanted() override;
  void publish_particles(const node::PosesOut& particles) override;
  void publish_hypotheses(const node::PosesOut& hypotheses) override;
  void publish_diagnostics(const node::DiagnosticOut& status) override;
  void send_transform(const node::TransformOut& transform) override;
  void publish_map_cloud(const node::CloudOut& cloud) override;
  std::optional<node::Stamp> now() override;
  void log(node::LogLevel level, const std::string& text) override;
  std::string parameter_name(const std::string& name) override;
  std::string static_transform_command(const std::string& parent, const std::string& child) override;

 private:
  void subscribe();

  ros::NodeHandle nh_, pnh_;
  node::NodeParameters parameters_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  ros::Publisher pose_pub_, particles_pub_, hypotheses_pub_, map_cloud_pub_, diagnostics_pub_;
  std::unique_ptr<node::LocalizationCore> core_;
  ros::CallbackQueue tf_queue_;
  std::unique_ptr<ros::AsyncSpinner> tf_spinner_;
  std::vector<ros::Subscriber> subscribers_;
  std::vector<ros::ServiceServer> services_;
};

}  // namespace tsdf_mcl::ros_node
