// The node's message and service callbacks (roscpp's spinner threads): tf, clouds, odometry, IMU, /initialpose and the
// services. Bad stamps and poses are rejected and counted here, before tf2 or the filter sees them; time going back
// restarts tf and the filter.
#include <cmath>
#include <cstdio>
#include <string>

#include "localization_node.hpp"
#include "ros_conversions.hpp"
#include "tsdf_mcl/core/one_line.hpp"

namespace tsdf_mcl::ros_node {
namespace {

constexpr double kOdometryKeepSeconds = 10.0;
constexpr double kImuKeepSeconds = 2.0;
// Time going back by more than this is a jump (a bag played again, a restarted simulator), not message latency;
// below tf2's 10 s cache, which would otherwise drop the new transforms as old data.
constexpr double kTimeJumpSeconds = 3.0;
// A coordinate beyond this (m) is corrupt: no map spans 1000 km, and float points lose all precision there.
constexpr double kMaxCoordinate = 1e6;
// ros::Duration holds +-2^31 s: stamps below 2^31 s keep every difference representable (tf2 and ros::Duration abort
// on larger ones).
constexpr std::uint32_t kMaxStampSeconds = 2147483647u;

std::string stamp_problem(const ros::Time& t) {
  if (t.sec < kMaxStampSeconds) return "";
  return "stamp " + std::to_string(t.sec) + " s is beyond 2^31 s (year 2038), where ROS time differences overflow";
}

// Why a pose (position, quaternion) cannot be used, or "".
std::string pose_problem(double x, double y, double z, const geometry_msgs::Quaternion& q) {
  char buf[160];
  if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z) || !std::isfinite(q.x) || !std::isfinite(q.y) ||
      !std::isfinite(q.z) || !std::isfinite(q.w)) {
    std::snprintf(buf, sizeof(buf), "non-finite pose (%g, %g, %g; quaternion %g, %g, %g, %g)", x, y, z, q.x, q.y, q.z,
                  q.w);
    return buf;
  }
  if (std::abs(x) > kMaxCoordinate || std::abs(y) > kMaxCoordinate || std::abs(z) > kMaxCoordinate) {
    std::snprintf(buf, sizeof(buf), "position (%g, %g, %g) m beyond %g m", x, y, z, kMaxCoordinate);
    return buf;
  }
  return "";
}

}  // namespace

void LocalizationNode::on_tf(const ros::MessageEvent<tf2_msgs::TFMessage const>& event, bool is_static) {
  const std::string authority = event.getPublisherName();
  std::lock_guard<std::mutex> lock(mutex_);
  note_time_locked(nullptr);  // before the transforms go in: a jump clears the buffer
  for (const geometry_msgs::TransformStamped& t : event.getMessage()->transforms) {
    const geometry_msgs::Vector3& v = t.transform.translation;
    std::string problem = stamp_problem(t.header.stamp);
    if (problem.empty()) problem = pose_problem(v.x, v.y, v.z, t.transform.rotation);
    if (!problem.empty()) {
      reject_locked(std::string(is_static ? "/tf_static " : "/tf ") + t.header.frame_id + " -> " + t.child_frame_id +
                    ": " + problem);
      continue;
    }
    if (is_static) statics_[t.child_frame_id] = t;
    tf_buffer_.setTransform(t, authority, is_static);
  }
}

void LocalizationNode::reject_locked(const std::string& why) {
  ++rejected_;
  last_rejection_ = one_line(why);
  // Every one of the first few, then at most one line per 5 s: a stream of bad messages does not flood the log.
  if (rejected_ <= 10)
    ROS_WARN("tsdf_mcl: message rejected (%zu so far): %s", rejected_, last_rejection_.c_str());
  else
    ROS_WARN_THROTTLE(5.0, "tsdf_mcl: message rejected (%zu so far): %s", rejected_, last_rejection_.c_str());
}

bool LocalizationNode::note_time_locked(const ros::Time* scan_stamp) {
  // Two signs: the clock going back (ROS time from /clock, as tf2_ros's listener checks it), or, without sim time,
  // the scans' stamps going back. Other messages' stamps are no sign: tf may be late (the node's own map -> odom
  // carries the stamp of a scan that took seconds).
  const ros::Time now = ros::Time::now();
  char why[160] = "";
  if (last_now_ && !now.isZero() && now < *last_now_) {
    std::snprintf(why, sizeof(why), "the clock went back from %.3f to %.3f s", last_now_->toSec(), now.toSec());
  } else if (scan_stamp && newest_ && (*newest_ - *scan_stamp).toSec() > kTimeJumpSeconds) {
    std::snprintf(why, sizeof(why), "scan stamps went back from %.3f to %.3f s", newest_->toSec(), scan_stamp->toSec());
  }
  if (!now.isZero()) last_now_ = now;
  if (why[0]) newest_.reset();
  if (scan_stamp && (!newest_ || *scan_stamp > *newest_)) newest_ = *scan_stamp;
  if (!why[0]) return false;
  ROS_WARN(
      "tsdf_mcl: %s (a bag played again or a restarted simulator): tf buffer cleared (static transforms kept), "
      "the filter restarts with a global search",
      why);
  tf_buffer_.clear();
  for (const auto& [child, t] : statics_) tf_buffer_.setTransform(t, "tsdf_mcl (kept across a time jump)", true);
  odometry_.clear();
  imu_.clear();
  last_imu_time_.reset();
  time_jump_pending_ = true;
  ++time_jumps_;
  return true;
}

bool LocalizationNode::stale_locked(double last, double incoming) const {
  // Time went back, and a message from before the jump reached this queue after it was cleared (another
  // connection, a loaded machine): without this, every later message would look out of order behind it.
  return incoming < last && newest_ && last - newest_->toSec() > kTimeJumpSeconds;
}

void LocalizationNode::restart_after_time_jump() {
  // A new Localizer: its particles, motion reference and IMU history all belong to the time before the jump.
  localizer_ = std::make_unique<Localizer>(map_, options_);
  last_stamp_.reset();
  scan_period_ = 0.0;
  last_sensor_scan_.clear();
  estimate_valid_ = false;
}

void LocalizationNode::on_cloud(std::size_t topic, const sensor_msgs::PointCloud2ConstPtr& msg) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (const std::string p = stamp_problem(msg->header.stamp); !p.empty()) {
      reject_locked("PointCloud2 on " + settings_.point_topics[topic] + ": " + p);
      return;
    }
    note_time_locked(topic == 0 ? &msg->header.stamp : nullptr);
    if (topic == 0 && latest_[0].fresh) ++skipped_;  // the filter is still busy with an older scan
    latest_[topic] = {msg, true};
  }
  if (topic == 0) cv_.notify_one();
}

void LocalizationNode::on_odometry(const nav_msgs::OdometryConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  const geometry_msgs::Point& p = msg->pose.pose.position;
  std::string problem = stamp_problem(msg->header.stamp);
  if (problem.empty()) problem = pose_problem(p.x, p.y, p.z, msg->pose.pose.orientation);
  if (!problem.empty()) {
    reject_locked("odometry on " + settings_.odom_topic + ": " + problem);
    return;
  }
  note_time_locked(nullptr);
  if (!odometry_.empty() && stale_locked(odometry_.back().header.stamp.toSec(), msg->header.stamp.toSec())) {
    odometry_.clear();
  }
  if (!odometry_.empty() && msg->header.stamp <= odometry_.back().header.stamp) {
    reject_locked("odometry on " + settings_.odom_topic + " stamped " + std::to_string(msg->header.stamp.toSec()) +
                  " s, not after the previous message (" + std::to_string(odometry_.back().header.stamp.toSec()) +
                  " s)");
    return;
  }
  odometry_.push_back(*msg);
  while (!odometry_.empty() && (msg->header.stamp - odometry_.front().header.stamp).toSec() > kOdometryKeepSeconds)
    odometry_.pop_front();
  odometry_cv_.notify_all();
}

void LocalizationNode::on_imu(const sensor_msgs::ImuConstPtr& msg) {
  const Eigen::Vector3d a(msg->linear_acceleration.x, msg->linear_acceleration.y, msg->linear_acceleration.z);
  std::string problem = stamp_problem(msg->header.stamp);
  // Beyond 1000 m/s^2 (100 g) no IMU of a robot reads: corrupt.
  if (problem.empty() && !(a.allFinite() && a.norm() < 1000.0)) {
    char buf[120];
    std::snprintf(buf, sizeof(buf), "linear_acceleration (%g, %g, %g) is not finite or beyond 1000 m/s^2", a.x(), a.y(),
                  a.z());
    problem = buf;
  }
  if (!problem.empty()) {
    std::lock_guard<std::mutex> lock(mutex_);
    reject_locked("IMU on " + settings_.imu_topic + ": " + problem);
    return;
  }
  // Specific force in the base frame: the IMU's mounting rotation from tf (the filter's sensor is the base).
  std::optional<Pose> base_T_imu = extrinsic(msg->header.frame_id, nullptr);
  if (!base_T_imu) return;
  ImuSample s;
  s.time = msg->header.stamp.toSec();
  s.acceleration = base_T_imu->rotation() * a;
  std::lock_guard<std::mutex> lock(mutex_);
  note_time_locked(nullptr);
  if (last_imu_time_ && stale_locked(*last_imu_time_, s.time)) {
    imu_.clear();
    last_imu_time_.reset();
  }
  if (last_imu_time_ && !(s.time > *last_imu_time_)) {
    reject_locked("IMU on " + settings_.imu_topic + " stamped " + std::to_string(s.time) +
                  " s, not after the previous sample (" + std::to_string(*last_imu_time_) + " s)");
    return;
  }
  last_imu_time_ = s.time;
  imu_.push_back(s);
  while (!imu_.empty() && s.time - imu_.front().time > kImuKeepSeconds) imu_.pop_front();
}

void LocalizationNode::on_initial_pose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& msg) {
  if (!msg->header.frame_id.empty() && msg->header.frame_id != settings_.global_frame_id) {
    ROS_WARN("tsdf_mcl: /initialpose in frame %s ignored (expected %s)", msg->header.frame_id.c_str(),
             settings_.global_frame_id.c_str());
    return;
  }
  const geometry_msgs::Point& p = msg->pose.pose.position;
  std::lock_guard<std::mutex> lock(mutex_);
  if (const std::string problem = pose_problem(p.x, p.y, p.z, msg->pose.pose.orientation); !problem.empty()) {
    reject_locked("/initialpose: " + problem);
    return;
  }
  ROS_INFO("tsdf_mcl: /initialpose received (%.2f, %.2f, %.2f): the filter restarts there at the next scan", p.x, p.y,
           p.z);
  initial_pose_request_ = *msg;
  global_request_ = false;
}

bool LocalizationNode::on_global_localization(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  std::lock_guard<std::mutex> lock(mutex_);
  global_request_ = true;
  initial_pose_request_.reset();
  ROS_INFO("tsdf_mcl: global localization requested: searching the whole map from the next scan");
  return true;
}

bool LocalizationNode::on_nomotion_update(std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
  std::lock_guard<std::mutex> lock(mutex_);
  nomotion_request_ = true;
  return true;
}

}  // namespace tsdf_mcl::ros_node
