#pragma once
// What the node core needs of a transport: publishing its outputs, the ROS clock, and a log. The ROS 1 node
// implements it with roscpp, the ROS 2 node with Cyclone DDS; the core (localization_core.hpp) never sees either.
#include <optional>
#include <string>

#include "node_messages.hpp"

namespace tsdf_mcl::node {

enum class LogLevel { kInfo, kWarn, kError };

class NodeOutput {
 public:
  virtual ~NodeOutput() = default;
  virtual void publish_pose(const PoseOut& pose) = 0;                 // amcl_pose
  virtual bool particles_wanted() = 0;                                // someone listens to the particle cloud
  virtual void publish_particles(const PosesOut& particles) = 0;      // particlecloud / particle_cloud
  virtual void publish_hypotheses(const PosesOut& hypotheses) = 0;    // ~hypotheses, best first
  virtual void publish_diagnostics(const DiagnosticOut& status) = 0;  // /diagnostics
  virtual void send_transform(const TransformOut& transform) = 0;     // tf map -> odom
  virtual void publish_map_cloud(const CloudOut& cloud) = 0;          // ~map_cloud, latched
  // The simulated ROS clock (/clock under sim time); nullopt on wall time or while /clock has said nothing yet. Time
  // going back is the clock's going back where there is one, else the scans' stamps'.
  virtual std::optional<Stamp> now() = 0;
  virtual void log(LogLevel level, const std::string& text) = 0;
  // A parameter (dotted name: sensor_extrinsics.lidar) as users of this transport write it (~sensor_extrinsics/lidar).
  virtual std::string parameter_name(const std::string& name) = 0;
  // How a user of this ROS publishes a static transform, for the hint when a LiDAR's mounting is missing.
  virtual std::string static_transform_command(const std::string& parent, const std::string& child) = 0;
};

}  // namespace tsdf_mcl::node
