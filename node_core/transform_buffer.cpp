#include "transform_buffer.hpp"

#include <chrono>
#include <cmath>
#include <limits>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"

namespace tsdf_mcl::node {

void TransformBuffer::set(const std::string& parent, const std::string& child, Stamp stamp, const Pose& parent_T_child,
                          bool is_static) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    tree_.add(parent, child, stamp.seconds(), parent_T_child, is_static);
    if (is_static) {
      statics_[child] = {parent, parent_T_child};
    } else if (stamp.seconds() > newest_) {
      newest_ = stamp.seconds();
      // Pruned once a second of stamps: the tree keeps a window, not hours of a robot's tf.
      if (newest_ - pruned_ > 1.0) {
        tree_.forget_older_than(kCacheSeconds);
        pruned_ = newest_;
      }
    }
  }
  changed_.notify_all();
}

void TransformBuffer::clear_moving() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    tree_ = TransformTree();
    for (const auto& [child, edge] : statics_) tree_.add(edge.first, child, 0.0, edge.second, true);
    newest_ = pruned_ = 0.0;
    ++interrupts_;
  }
  changed_.notify_all();
}

void TransformBuffer::interrupt() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++interrupts_;
  }
  changed_.notify_all();
}

std::optional<Pose> TransformBuffer::try_lookup_locked(const std::string& target, const std::string& source,
                                                       std::optional<Stamp> stamp, std::string* error) const {
  try {
    double t = 0.0;
    if (stamp) {
      t = stamp->seconds();
    } else {
      const auto [first, last] = tree_.coverage(target, source);
      if (first > last) throw Error("the moving transforms between them cover no common time");
      t = std::isinf(last) ? 0.0 : last;
    }
    return tree_.lookup(target, source, t);
  } catch (const Error& e) {
    if (error) *error = one_line(e.what());
    return std::nullopt;
  }
}

bool TransformBuffer::can_lookup(const std::string& target, const std::string& source, std::optional<Stamp> stamp) {
  std::lock_guard<std::mutex> lock(mutex_);
  return try_lookup_locked(target, source, stamp, nullptr).has_value();
}

std::optional<Pose> TransformBuffer::lookup(const std::string& target, const std::string& source,
                                            std::optional<Stamp> stamp, double timeout, std::string* error) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout);
  std::unique_lock<std::mutex> lock(mutex_);
  const std::uint64_t interrupts = interrupts_;
  std::optional<Pose> pose;
  // Each new transform wakes the wait: the lookup is tried again then, never on a timer.
  changed_.wait_until(lock, deadline, [&] {
    pose = try_lookup_locked(target, source, stamp, error);
    return pose.has_value() || interrupts_ != interrupts;
  });
  return pose;
}

}  // namespace tsdf_mcl::node
