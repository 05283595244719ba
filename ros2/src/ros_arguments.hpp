#pragma once
// The command line of tsdf_mcl_ros2 as a ROS 2 node's (rcl/include/rcl/arguments.h): after --ros-args, remap rules
// (-r from:=to, __ns:=/ns and __node:=name among them), parameters (-p name:=value) and parameter files
// (--params-file FILE, `<node>: ros__parameters: ...`, node names with the wildcards * and **), up to -- or the end.
// Logging and enclave options are accepted and noted as unused; anything else is an Error in one line.
#include <string>
#include <vector>

#include "node_parameters.hpp"
#include "ros_names.hpp"

namespace tsdf_mcl::ros2_node {

struct RosArguments {
  NodeName node;
  std::vector<Remap> remaps;
  // This node's parameters: its entries of the parameter files in command-line order (an entry naming the node
  // wins over a wildcard one in the same file), then -p, each later value replacing an earlier one.
  node::NodeParameters parameters;
  std::vector<std::string> notes;  // options accepted but not used (logging, enclave)
  bool help = false;
};

RosArguments parse_ros_arguments(const std::vector<std::string>& args);

// Whether the node name pattern of a parameter file (/**, /robot1/*, tsdf_mcl, /ns/tsdf_mcl) names the node
// `fully_qualified` (/ns/name): * is one part of the name, ** any number; a pattern without a leading / is taken from
// the root, as rclcpp reads it.
bool node_pattern_matches(const std::string& pattern, const std::string& fully_qualified);

// A value's type from its text, as YAML's core schema reads a plain scalar: a whole number, another number (.nan,
// .inf included), true/false, else text; [a, b] is a list.
node::ParameterValue typed_value(const std::string& text);

}  // namespace tsdf_mcl::ros2_node
