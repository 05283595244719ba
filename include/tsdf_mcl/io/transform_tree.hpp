#pragma once
// A tf tree over time, without ROS: what a bag's /tf and /tf_static hold, queried as tf2's lookupTransform is, for
// the bag reader (Dataset::open_bag). Every frame has one parent; a static edge (from /tf_static) holds at all
// times, a dynamic edge (from /tf) is interpolated between its two samples around the query time (linear in
// translation, slerp in rotation) and is not extrapolated: outside its first..last sample it is an Error that
// names the edge and the times it covers.
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"

namespace tsdf_mcl {

// The pose a fraction f of the way from a to b: linear in translation, slerp in rotation.
Pose interpolate_pose(const Pose& a, const Pose& b, double f);

class TransformTree {
 public:
  // parent_T_child at `time` (s). A sample at the time of an earlier one replaces it, as does a later static
  // transform of the same child. Throws Error where the child already has another parent, or where one edge is
  // given both static and dynamic transforms.
  void add(const std::string& parent, const std::string& child, double time, const Pose& parent_T_child,
           bool is_static);

  // target_T_source at `time`: the chains from both frames up to their common ancestor, each edge at `time`.
  // Throws Error naming both frames where no chain connects them, or the edge that does not reach `time`.
  Pose lookup(const std::string& target, const std::string& source, double time) const;

  // The times at which lookup(target, source, t) succeeds: the overlap of the sample ranges of the dynamic edges
  // between them ({-inf, +inf} where they are all static; an empty range has first > second). Throws like lookup
  // where no chain connects them.
  std::pair<double, double> coverage(const std::string& target, const std::string& source) const;

  // Drops the samples of each dynamic edge that lie more than `keep` seconds before its newest one (a node's live tf
  // stream, which tf2 keeps for 10 s), so that the tree stays small over hours.
  void forget_older_than(double keep);

  // True if the frame occurs as a parent or a child.
  bool has_frame(const std::string& frame) const;
  // Every frame, sorted, for error messages.
  std::vector<std::string> frames() const;
  std::size_t edges() const { return edges_.size(); }

 private:
  struct Edge {
    std::string parent;
    bool is_static = false;
    std::vector<std::pair<double, Pose>> samples;  // by time
  };
  // The frames from `frame` up to its root, `frame` first.
  std::vector<std::string> chain(const std::string& frame) const;
  // ancestor_T_frame at `time`, `ancestor` on frame's chain.
  Pose down_to(const std::string& ancestor, const std::string& frame, double time) const;
  std::string common_ancestor(const std::string& target, const std::string& source) const;
  static Pose at(const std::string& child, const Edge& edge, double time);

  std::map<std::string, Edge> edges_;  // by child frame
};

}  // namespace tsdf_mcl
