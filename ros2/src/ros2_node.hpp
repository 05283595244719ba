#pragma once
// The ROS 2 node over DDS: Cyclone DDS's transport for the node core (node_core/localization_core.hpp), which holds
// everything else (the checks, tf, the filter, what is published when). On the wire it is a ROS 2 node: ROS 2's
// topic names (ros_names.hpp), type names and CDR encoding (ros2/idl), QoS (dds_endpoints.hpp) and service framing
// (empty_service.hpp), in the domain ROS_DOMAIN_ID names (dds_domain.hpp); names and QoS follow nav2 AMCL's.
//
// In:  PointCloud2 on `point_topics` (sensor data QoS: best effort, or reliable with cloud_reliability), /tf
//      (reliable, volatile) and /tf_static (reliable, transient local), nav_msgs/Odometry on `odom_topic` and
//      sensor_msgs/Imu on `imu_topic` (best effort: any publisher matches), initialpose (reliable), /clock when
//      use_sim_time, ~/reinitialize_global_localization (std_msgs/Empty, a trigger any DDS client can send).
//      Services reinitialize_global_localization and request_nomotion_update (std_srvs/Empty).
// Out: amcl_pose (reliable, transient local), particle_cloud (nav2_msgs/ParticleCloud, best effort), ~/hypotheses
//      (nav2_msgs/ParticleCloud: the ranked places, weight = share, best first), /tf map -> odom, ~/map_cloud
//      (PointCloud2, transient local), /diagnostics.
//
// Threads: one for tf and the clock, one for the other messages and the services, and the caller's, which runs the
// filter (LocalizationCore::run): a lookup that waits for tf never blocks the tf it waits for.
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "dds_domain.hpp"
#include "dds_endpoints.hpp"
#include "empty_service.hpp"
#include "localization_core.hpp"
#include "node_output.hpp"
#include "ros_arguments.hpp"
#include "ros_names.hpp"

namespace tsdf_mcl::ros2_node {

// The node's own parameters beside the core's: ROS 2's use_sim_time, and the clouds' reliability.
struct Ros2Settings {
  bool use_sim_time = false;
  bool reliable_clouds = false;  // cloud_reliability: best_effort (default) or reliable
};
Ros2Settings ros2_settings_from(const node::NodeParameters& parameters);

class Ros2Node : public node::NodeOutput {
 public:
  // Reads the parameters, joins the domain, starts the core (which loads the map), then subscribes. Throws Error for
  // bad parameters, names or map.
  Ros2Node(const RosArguments& arguments, const DomainConfig& domain);
  ~Ros2Node() override;
  // Processes scans until `ok` turns false.
  void run(const std::function<bool()>& ok);

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
  std::string topic(const std::string& name) const { return dds_topic(names_.resolve(name)); }

  RosArguments arguments_;
  NameResolver names_;
  Ros2Settings ros2_;
  node::NodeSettings settings_;
  LocalizerOptions options_;
  Participant participant_;
  Writer pose_, particles_, hypotheses_, diagnostics_, tf_, map_cloud_;
  std::unique_ptr<node::LocalizationCore> core_;
  std::vector<std::unique_ptr<Reader>> readers_;
  std::vector<std::unique_ptr<EmptyService>> services_;
  std::unique_ptr<MessageLoop> tf_loop_, message_loop_;
  std::mutex clock_mutex_;
  std::optional<node::Stamp> sim_time_;  // the latest /clock
  std::mutex log_mutex_;
};

}  // namespace tsdf_mcl::ros2_node
