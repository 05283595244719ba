#pragma once
// tf for the node core, without tf2: the transforms of /tf and /tf_static (checked by the core before they come
// here) in a TransformTree that keeps the last kCacheSeconds of each moving edge, as tf2's buffer does, and lookups
// that wait for a transform still on its way. Thread-safe: transports add transforms on their threads while the
// filter thread looks up.
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>

#include "node_messages.hpp"
#include "tsdf_mcl/io/transform_tree.hpp"

namespace tsdf_mcl::node {

class TransformBuffer {
 public:
  static constexpr double kCacheSeconds = 10.0;  // tf2's default cache

  // parent_T_child at `stamp`. Throws Error where it contradicts the tree: another parent for the child, a static
  // edge sent on /tf, a frame to itself.
  void set(const std::string& parent, const std::string& child, Stamp stamp, const Pose& parent_T_child,
           bool is_static);
  // Time went back: the moving transforms go, the static ones stay; waiting lookups return.
  void clear_moving();

  // target_T_source at `stamp` (nullopt: the latest time both are known, for rigid mountings). Waits up to `timeout`
  // seconds of wall time for it (tf on its way from another connection), unless interrupt() is called meanwhile.
  // nullopt where it does not come; `error` (where given) says why.
  std::optional<Pose> lookup(const std::string& target, const std::string& source, std::optional<Stamp> stamp,
                             double timeout, std::string* error = nullptr);
  // Whether lookup would succeed now without waiting.
  bool can_lookup(const std::string& target, const std::string& source, std::optional<Stamp> stamp);
  // Ends the waits of lookups in progress.
  void interrupt();

 private:
  // target_T_source now, or nullopt with `error` (the caller holds mutex_).
  std::optional<Pose> try_lookup_locked(const std::string& target, const std::string& source,
                                        std::optional<Stamp> stamp, std::string* error) const;

  std::mutex mutex_;
  std::condition_variable changed_;
  TransformTree tree_;
  std::map<std::string, std::pair<std::string, Pose>> statics_;  // by child: parent, transform (kept across a clear)
  std::uint64_t interrupts_ = 0;
  double newest_ = 0.0;  // s, the newest moving sample
  double pruned_ = 0.0;  // s, newest_ at the last pruning
};

}  // namespace tsdf_mcl::node
