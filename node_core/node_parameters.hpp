#pragma once
// The node's parameters, for both nodes: its own (NodeSettings) and the filter's by the library schema's names
// (tsdf_mcl/localizer/localizer_parameters.hpp), read from the values a transport collected (ROS 1's parameter
// server, a ROS 2 params file and -p on the command line). A bad value is an Error naming the parameter the way the
// transport names it (~transform_tolerance, transform_tolerance) and what it must be, never a silent default.
#include <map>
#include <string>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"

namespace tsdf_mcl::node {

// A value as the transport's parameter source typed it.
struct ParameterValue {
  enum class Type { kBool, kInteger, kDouble, kString, kList, kOther };
  Type type = Type::kString;
  std::string text;  // numbers at full precision, list items joined by ","; for kOther, what it is
};

struct NodeParameters {
  // By dotted name: initial_pose.x, sensor_extrinsics.lidar (ROS 1's ~initial_pose/x, a ROS 2 file's nesting).
  std::map<std::string, ParameterValue> values;
  std::string prefix;    // "~" (ROS 1) or "" (ROS 2)
  char separator = '.';  // '/' (ROS 1) or '.' (ROS 2)
  // `name` as the user wrote it: ~initial_pose/x, initial_pose.x.
  std::string shown(const std::string& name) const;
};

struct NodeSettings {
  std::string map_file;
  std::string global_frame_id = "map";
  std::string odom_frame_id = "odom";
  std::string base_frame_id = "base_link";
  std::vector<std::string> point_topics = {"points"};
  std::string odom_topic;            // empty: odometry from tf
  std::string imu_topic;             // empty: no IMU
  double transform_tolerance = 0.1;  // s added to the map -> odom stamp (nav2 AMCL's meaning)
  double tf_timeout = 0.2;           // s to wait for a transform at a scan's stamp
  double merge_window = 0.1;         // s: clouds of the other topics within this of the first topic's scan are merged
  bool tf_broadcast = true;
  int max_published_particles = 2000;
  int map_cloud_points = 300000;
  // base_frame_id -> frame, by the frame's name: the LiDAR's (or IMU's) mounting where no tf provides it (a robot
  // without robot_state_publisher, a bag recorded without /tf_static). tf wins where it has the transform.
  std::map<std::string, Pose> sensor_extrinsics;
  // The last converged pose, kept across restarts (last_pose_file.hpp); empty: not kept. The transport gives the
  // default (a file in ROS_HOME).
  std::string last_pose_file;
};

// The node's own parameters: map_file (required), the frames (global_frame_id not empty; base_frame_id neither
// empty nor the global frame; odom_frame_id neither empty, nor the base frame, nor the global frame), topics, tf
// timing, what it publishes, sensor_extrinsics, last_pose_file (`fallback_last_pose_file` where not given).
NodeSettings settings_from(const NodeParameters& parameters, const std::string& fallback_last_pose_file);

// The filter parameters, by the library schema's names (nav2 AMCL's where they exist, ROS 1 amcl's as aliases), with
// the schema's validation: the node is a plain adapter over it.
LocalizerOptions localizer_options_of(const NodeParameters& parameters);

// One warning per parameter that neither the schema, the node's own nor `transport_names` (the transport's own:
// use_sim_time, ...) knows, with the closest known names: a misspelt parameter would otherwise be silently ignored.
std::vector<std::string> unknown_parameter_warnings(const NodeParameters& parameters,
                                                    const std::vector<std::string>& transport_names);

// Where a node keeps its last pose unless last_pose_file says: ROS_HOME (else ~/.ros), by the node's fully qualified
// name (/robot1/tsdf_mcl: robot1_tsdf_mcl_last_pose.json); "" without either variable.
std::string default_last_pose_file(const std::string& node_name);

// The node's own parameter names (NodeSettings), for the transports' documentation checks.
const std::vector<std::string>& node_parameter_names();

}  // namespace tsdf_mcl::node
