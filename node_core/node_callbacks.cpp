// The core's message and request callbacks (the transport's threads): tf, clouds, odometry, IMU, /initialpose and
// the requests. Bad stamps and poses are rejected and counted here (message_checks.hpp), before tf or the filter
// sees them; time going back restarts tf and the filter.
#include <cmath>
#include <cstdio>
#include <string>

#include "localization_core.hpp"
#include "message_checks.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"

namespace tsdf_mcl::node {
namespace {

constexpr double kOdometryKeepSeconds = 10.0;
constexpr double kImuKeepSeconds = 2.0;
// Time going back by more than this is a jump (a bag played again, a restarted simulator), not message latency;
// below the tf cache's 10 s, which would otherwise keep the old transforms.
constexpr double kTimeJumpSeconds = 3.0;

std::string seconds_text(Stamp t) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.6f", t.seconds());
  return buf;
}

}  // namespace

void LocalizationCore::log_throttled(const std::string& key, double seconds, LogLevel level, const std::string& text) {
  const auto now = std::chrono::steady_clock::now();
  {
    std::lock_guard<std::mutex> lock(log_mutex_);
    const auto last = throttled_.find(key);
    if (last != throttled_.end() && now - last->second < std::chrono::duration<double>(seconds)) return;
    throttled_[key] = now;
  }
  out_.log(level, text);
}

void LocalizationCore::reject_locked(const std::string& why) {
  ++rejected_;
  last_rejection_ = one_line(why);
  const std::string line = "tsdf_mcl: message rejected (" + std::to_string(rejected_) + " so far): " + last_rejection_;
  // Every one of the first few, then at most one line per 5 s: a stream of bad messages does not flood the log.
  if (rejected_ <= 10)
    out_.log(LogLevel::kWarn, line);
  else
    log_throttled("rejected", 5.0, LogLevel::kWarn, line);
}

std::optional<Stamp> LocalizationCore::checked_stamp_locked(const RawStamp& stamp, const std::string& what) {
  const std::string problem = stamp_problem(stamp);
  if (problem.empty()) return to_stamp(stamp);
  reject_locked(what + ": " + problem);
  return std::nullopt;
}

bool LocalizationCore::note_time_locked(const Stamp* scan_stamp) {
  // Under a simulated clock, the clock going back (as tf2's listener checks it); without one, the scans' stamps going
  // back. Not both: the clock's step back and the scans' come on different connections, and would restart the filter
  // twice. Other messages' stamps are no sign: tf may be late (the node's own map -> odom carries the stamp of a scan
  // that took seconds).
  const std::optional<Stamp> now = out_.now();
  char why[160] = "";
  if (now) {
    if (last_now_ && *now < *last_now_) {
      std::snprintf(why, sizeof(why), "the clock went back from %.3f to %.3f s", last_now_->seconds(), now->seconds());
    }
    last_now_ = now;
  } else if (scan_stamp && newest_ && seconds_between(*scan_stamp, *newest_) > kTimeJumpSeconds) {
    std::snprintf(why, sizeof(why), "scan stamps went back from %.3f to %.3f s", newest_->seconds(),
                  scan_stamp->seconds());
  }
  if (why[0]) newest_.reset();
  if (scan_stamp && (!newest_ || *scan_stamp > *newest_)) newest_ = *scan_stamp;
  if (!why[0]) return false;
  out_.log(LogLevel::kWarn, std::string("tsdf_mcl: ") + why +
                                " (a bag played again or a restarted simulator): tf cleared (static transforms "
                                "kept), the filter restarts with a global search");
  tf_.clear_moving();
  odometry_.clear();
  imu_.clear();
  last_imu_time_.reset();
  time_jump_pending_ = true;
  ++time_jumps_;
  odometry_cv_.notify_all();
  return true;
}

bool LocalizationCore::stale_locked(Stamp last, Stamp incoming) const {
  // Time went back, and a message from before the jump reached this queue after it was cleared (another connection,
  // a loaded machine): without this, every later message would look out of order behind it.
  return incoming < last && newest_ && seconds_between(*newest_, last) > kTimeJumpSeconds;
}

void LocalizationCore::restart_after_time_jump() {
  // A new Localizer: its particles, motion reference and IMU history all belong to the time before the jump.
  localizer_ = std::make_unique<Localizer>(map_, options_);
  last_stamp_.reset();
  scan_period_ = 0.0;
  last_sensor_scan_.clear();
  estimate_valid_ = false;
  if (last_pose_) last_pose_->forget_start();
}

void LocalizationCore::on_clock() {
  std::lock_guard<std::mutex> lock(mutex_);
  note_time_locked(nullptr);
}

void LocalizationCore::on_tf(const std::vector<TransformMsg>& transforms, bool is_static) {
  std::lock_guard<std::mutex> lock(mutex_);
  note_time_locked(nullptr);  // before the transforms go in: a jump clears the buffer
  for (const TransformMsg& t : transforms) {
    const std::string what =
        std::string(is_static ? "/tf_static " : "/tf ") + t.header.frame_id + " -> " + t.child_frame_id;
    const std::optional<Stamp> stamp = checked_stamp_locked(t.header.stamp, what);
    if (!stamp) continue;
    if (const std::string problem = pose_problem(t.transform, false); !problem.empty()) {
      reject_locked(what + ": " + problem);
      continue;
    }
    try {
      tf_.set(t.header.frame_id, t.child_frame_id, *stamp, to_pose(t.transform), is_static);
    } catch (const Error& e) {
      reject_locked(what + ": " + e.what());
    }
  }
}

void LocalizationCore::on_cloud(std::size_t topic, const CloudMsg& msg) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const std::optional<Stamp> stamp =
        checked_stamp_locked(msg.header.stamp, "PointCloud2 on " + settings_.point_topics[topic]);
    if (!stamp) return;
    note_time_locked(topic == 0 ? &*stamp : nullptr);
    if (topic == 0 && latest_[0].fresh) ++skipped_;  // the filter is still busy with an older scan
    latest_[topic] = {msg, *stamp, true};
  }
  if (topic == 0) scan_cv_.notify_one();
}

void LocalizationCore::on_odometry(const OdometryMsg& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string what = "odometry on " + settings_.odom_topic;
  const std::optional<Stamp> stamp = checked_stamp_locked(msg.header.stamp, what);
  if (!stamp) return;
  if (const std::string problem = pose_problem(msg.pose, true); !problem.empty()) {
    reject_locked(what + ": " + problem);
    return;
  }
  note_time_locked(nullptr);
  if (!odometry_.empty() && stale_locked(odometry_.back().stamp, *stamp)) odometry_.clear();
  if (!odometry_.empty() && *stamp <= odometry_.back().stamp) {
    reject_locked(what + " stamped " + seconds_text(*stamp) + " s, not after the previous message (" +
                  seconds_text(odometry_.back().stamp) + " s)");
    return;
  }
  odometry_.push_back({*stamp, to_pose(msg.pose)});
  while (!odometry_.empty() && seconds_between(odometry_.front().stamp, *stamp) > kOdometryKeepSeconds)
    odometry_.pop_front();
  odometry_cv_.notify_all();
}

void LocalizationCore::on_imu(const ImuMsg& msg) {
  const std::string what = "IMU on " + settings_.imu_topic;
  std::optional<Stamp> stamp;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stamp = checked_stamp_locked(msg.header.stamp, what);
    if (!stamp) return;
    if (const std::string problem = imu_problem(msg); !problem.empty()) {
      reject_locked(what + ": " + problem);
      return;
    }
  }
  // Specific force in the base frame: the IMU's mounting rotation from tf (the filter's sensor is the base).
  const std::optional<Pose> base_T_imu = extrinsic(msg.header.frame_id, nullptr);
  if (!base_T_imu) return;
  ImuSample s;
  s.time = stamp->seconds();
  s.acceleration = base_T_imu->rotation() * msg.linear_acceleration;
  std::lock_guard<std::mutex> lock(mutex_);
  note_time_locked(nullptr);
  if (last_imu_time_ && stale_locked(*last_imu_time_, *stamp)) {
    imu_.clear();
    last_imu_time_.reset();
  }
  if (last_imu_time_ && !(*stamp > *last_imu_time_)) {
    reject_locked(what + " stamped " + seconds_text(*stamp) + " s, not after the previous sample (" +
                  seconds_text(*last_imu_time_) + " s)");
    return;
  }
  last_imu_time_ = stamp;
  imu_.push_back(s);
  while (!imu_.empty() && s.time - imu_.front().time > kImuKeepSeconds) imu_.pop_front();
}

void LocalizationCore::on_initial_pose(const InitialPoseMsg& msg) {
  if (!msg.header.frame_id.empty() && msg.header.frame_id != settings_.global_frame_id) {
    out_.log(LogLevel::kWarn, "tsdf_mcl: /initialpose in frame " + one_line(msg.header.frame_id) +
                                  " ignored (expected " + settings_.global_frame_id + ")");
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  std::string problem = pose_problem(msg.pose, true);
  if (problem.empty()) problem = outside_map_problem(map_, msg.pose.position);
  if (!problem.empty()) {
    reject_locked("/initialpose: " + problem);
    return;
  }
  const Eigen::Vector3d& p = msg.pose.position;
  char buf[160];
  std::snprintf(buf, sizeof(buf),
                "tsdf_mcl: /initialpose received (%.2f, %.2f, %.2f): the filter restarts there at the next scan", p.x(),
                p.y(), p.z());
  out_.log(LogLevel::kInfo, buf);
  initial_pose_request_ = to_pose(msg.pose);
  global_request_ = false;
}

void LocalizationCore::request_global_localization() {
  std::lock_guard<std::mutex> lock(mutex_);
  global_request_ = true;
  initial_pose_request_.reset();
  out_.log(LogLevel::kInfo, "tsdf_mcl: global localization requested: searching the whole map from the next scan");
}

void LocalizationCore::request_nomotion_update() {
  std::lock_guard<std::mutex> lock(mutex_);
  nomotion_request_ = true;
}

}  // namespace tsdf_mcl::node
