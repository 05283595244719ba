#pragma once
// What a node published, by scan stamp, as a test's link hears it on whatever threads deliver it: the statuses, the
// poses and map -> odom. heard() and map_odom() wait on a condition variable that each delivery wakes.
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>

#include "node_link.hpp"

namespace tsdf_mcl::node::test {

class HeardRecord {
 public:
  // `transform_tolerance`: what the node adds to a scan's stamp for map -> odom.
  explicit HeardRecord(double transform_tolerance)
      : tolerance_ns_(static_cast<std::int64_t>(transform_tolerance * 1e9)) {}

  // A scan about to be sent at `stamp`: what was heard for an earlier scan of that stamp (a replay) goes.
  void forget(Stamp stamp) {
    std::lock_guard<std::mutex> lock(mutex_);
    statuses_.erase(stamp.ns);
    poses_.erase(stamp.ns);
    map_odom_.erase(stamp.ns);
  }
  void status(const DiagnosticOut& s) {
    record([&] { statuses_[s.stamp.ns] = s; });
  }
  void pose(const PoseOut& p) {
    record([&] { poses_[p.stamp.ns] = p; });
  }
  void map_odom(const TransformOut& t) {
    record([&] { map_odom_[t.stamp.ns - tolerance_ns_] = t; });
  }

  // The status of the scan at `stamp`, with its pose where the scan was used: the pose goes out before the status,
  // but may come on another connection.
  std::optional<Heard> heard(Stamp stamp, std::chrono::seconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!cv_.wait_for(lock, timeout, [&] { return statuses_.count(stamp.ns) > 0; })) return std::nullopt;
    Heard h;
    h.status = statuses_.at(stamp.ns);
    if (h.used()) cv_.wait_for(lock, timeout, [&] { return poses_.count(stamp.ns) > 0; });
    if (const auto p = poses_.find(stamp.ns); p != poses_.end()) h.pose = p->second;
    return h;
  }
  std::optional<TransformOut> map_odom(Stamp scan, std::chrono::seconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!cv_.wait_for(lock, timeout, [&] { return map_odom_.count(scan.ns) > 0; })) return std::nullopt;
    return map_odom_.at(scan.ns);
  }

 private:
  template <typename F>
  void record(F f) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      f();
    }
    cv_.notify_all();
  }
  std::int64_t tolerance_ns_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::map<std::int64_t, DiagnosticOut> statuses_;
  std::map<std::int64_t, PoseOut> poses_;
  std::map<std::int64_t, TransformOut> map_odom_;
};

}  // namespace tsdf_mcl::node::test
