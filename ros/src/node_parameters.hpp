#pragma once
// The node's parameters from its private namespace (node_parameters.cpp): a bad value is an Error naming the
// parameter and what it must be, never a silent default.
#include <ros/ros.h>

#include "localization_node.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"

namespace tsdf_mcl::ros_node {

// The node's own parameters (~map_file, the frames and topics, tf timing, what it publishes, ~sensor_extrinsics).
NodeSettings settings_from(const ros::NodeHandle& pnh);

// A misspelt parameter would otherwise be silently ignored.
void warn_unknown_parameters(const ros::NodeHandle& pnh);

// The filter parameters, by the library schema's names (nav2 AMCL's where they exist, ROS 1 amcl's as aliases),
// from the private namespace, with the schema's validation: the node is a plain adapter over it.
LocalizerOptions localizer_options_of(const ros::NodeHandle& pnh);

}  // namespace tsdf_mcl::ros_node
