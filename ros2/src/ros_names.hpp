#pragma once
// ROS 2's names, as rcl resolves them (rcl/src/rcl/expand_topic_name.c, remap.c, validate_topic_name.c): a node's
// name and namespace, topic and service names absolute ("/tf"), relative ("points": in the node's namespace) or
// private ("~/hypotheses": in the node's own), remap rules `from:=to` applied to the expanded name, and the DDS topic
// names rmw_cyclonedds_cpp makes of them (namespace_prefix.hpp): rt<name> for a topic, rq<name>Request and
// rr<name>Reply for a service.
#include <string>
#include <utility>
#include <vector>

namespace tsdf_mcl::ros2_node {

struct NodeName {
  std::string name = "tsdf_mcl";
  std::string ns = "/";  // absolute, no trailing slash except the root's
  // "/ns/name".
  std::string fully_qualified() const;
};

struct Remap {
  std::string node;  // empty: every node; else only the node of this name
  std::string from, to;
};

// Why `name` is not a valid ROS 2 topic name ("" when it is): tokens of letters, digits and underscores that do not
// start with a digit, separated by single slashes, "~" only as the first token.
std::string topic_name_problem(const std::string& name);

class NameResolver {
 public:
  NameResolver(NodeName node, std::vector<Remap> remaps) : node_(std::move(node)), remaps_(std::move(remaps)) {}
  // The fully qualified name of topic or service `name` after expansion and remapping. Throws Error naming it where
  // the name or a remap's result is invalid.
  std::string resolve(const std::string& name) const;
  const NodeName& node() const { return node_; }

 private:
  std::string expand(const std::string& name) const;
  NodeName node_;
  std::vector<Remap> remaps_;
};

std::string dds_topic(const std::string& fully_qualified);          // rt/points
std::string dds_request_topic(const std::string& fully_qualified);  // rq/reinitialize_global_localizationRequest
std::string dds_reply_topic(const std::string& fully_qualified);    // rr/reinitialize_global_localizationReply

}  // namespace tsdf_mcl::ros2_node
