// The core's setup, its run loop and a scan's way through tf and the filter; the callbacks are in
// node_callbacks.cpp, what it publishes in node_status.cpp.
#include "localization_core.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>

#include "message_checks.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"
#include "tsdf_mcl/io/transform_tree.hpp"
#include "tsdf_mcl/localizer/planar_pose.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "tsdf_mcl/map/map_surface.hpp"

namespace tsdf_mcl::node {
namespace {

// The heading of a pose's x axis in the world's x-y plane (rad), for logs.
double yaw_of(const Pose& p) {
  const Eigen::Vector3d x = p.rotation().col(0);
  return std::atan2(x.y(), x.x());
}

}  // namespace

LocalizationCore::LocalizationCore(const NodeSettings& settings, const LocalizerOptions& options, NodeOutput& output)
    : settings_(settings), options_(options), out_(output) {
  map_ = load_map(settings_.map_file);
  LocalizerOptions start = options_;
  if (!settings_.last_pose_file.empty()) {
    last_pose_ = std::make_unique<LastPoseFile>(settings_.last_pose_file, map_);
    std::string note, warning;
    if (const std::optional<Pose> kept = last_pose_->start(options_, &note, &warning)) start.initial_pose = kept;
    if (!warning.empty()) out_.log(LogLevel::kWarn, "tsdf_mcl: " + warning);
    if (!note.empty()) out_.log(LogLevel::kInfo, "tsdf_mcl: " + note);
  }
  localizer_ = std::make_unique<Localizer>(map_, start);
  out_.log(LogLevel::kInfo, "tsdf_mcl: map " + one_line(settings_.map_file) + ", " + localizer_->backend_note());
  latest_.resize(settings_.point_topics.size());

  CloudOut surface;
  surface.cloud = encode_pointcloud2(map_surface(map_, static_cast<std::size_t>(settings_.map_cloud_points)));
  surface.frame_id = settings_.global_frame_id;
  surface.stamp = out_.now().value_or(Stamp{});
  out_.publish_map_cloud(surface);
}

LocalizationCore::~LocalizationCore() {
  if (!last_pose_) return;
  try {
    last_pose_->flush();
  } catch (const Error& e) {
    out_.log(LogLevel::kWarn, std::string("tsdf_mcl: ") + e.what());
  }
}

void LocalizationCore::run(const std::function<bool()>& ok) {
  while (ok()) {
    CloudMsg primary;
    Stamp stamp;
    std::vector<CloudMsg> others;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      scan_cv_.wait_for(lock, std::chrono::milliseconds(100), [this] { return latest_[0].fresh; });
      if (!latest_[0].fresh) continue;
      primary = *latest_[0].cloud;
      stamp = latest_[0].stamp;
      latest_[0].fresh = false;
      for (std::size_t k = 1; k < latest_.size(); ++k) {
        if (latest_[k].cloud && std::abs(seconds_between(latest_[k].stamp, stamp)) <= settings_.merge_window)
          others.push_back(*latest_[k].cloud);
      }
    }
    process(primary, stamp, others);
  }
}

void LocalizationCore::apply_requests(Stamp stamp) {
  std::optional<Pose> pose_request;
  bool global = false, nomotion = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::swap(pose_request, initial_pose_request_);
    std::swap(global, global_request_);
    std::swap(nomotion, nomotion_request_);
  }
  if (global) {
    localizer_->reset_global();
    if (last_pose_) last_pose_->forget_start();
    ++counters_.global_searches;
  }
  if (nomotion) localizer_->request_update();
  if (!pose_request) return;
  Pose pose = *pose_request;
  const Eigen::Quaterniond q(pose.rotation());
  const bool planar = pose.translation().z() == 0.0 && std::abs(q.x()) < 1e-6 && std::abs(q.y()) < 1e-6;
  if (planar) {
    // RViz's "2D Pose Estimate": z, roll and pitch from the map and the last scan.
    const std::optional<double> z_hint =
        estimate_valid_ ? std::optional<double>(localizer_->estimate().pose.translation().z()) : std::nullopt;
    if (const auto full = pose_from_planar(map_, pose.translation().x(), pose.translation().y(), yaw_of(pose),
                                           last_sensor_scan_, last_base_T_sensor_, z_hint)) {
      pose = *full;
    } else {
      out_.log(LogLevel::kWarn,
               "tsdf_mcl: /initialpose left z, roll and pitch 0 and the map or the last scan shows no floor there: "
               "using them as given");
    }
  }
  const Eigen::Vector3d t = pose.translation();
  char buf[200];
  std::snprintf(buf, sizeof(buf), "tsdf_mcl: initial pose %.2f %.2f %.2f, yaw %.1f deg%s (stamp %.3f)", t.x(), t.y(),
                t.z(), yaw_of(pose) * 180.0 / M_PI, planar ? " (z, roll, pitch from the map)" : "", stamp.seconds());
  out_.log(LogLevel::kInfo, buf);
  try {
    localizer_->reset_to(pose);  // a pose outside the map is refused (map_extent_checks.hpp)
  } catch (const Error& e) {
    out_.log(LogLevel::kWarn, "tsdf_mcl: /initialpose refused: " + one_line(e.what()));
    return;
  }
  if (last_pose_) last_pose_->forget_start();
  ++counters_.initial_poses;
}

std::optional<Pose> LocalizationCore::odometry_at(Stamp stamp, std::string* error) {
  if (settings_.odom_topic.empty()) {
    std::string why;
    const std::optional<Pose> pose =
        tf_.lookup(settings_.odom_frame_id, settings_.base_frame_id, stamp, settings_.tf_timeout, &why);
    if (!pose) {
      *error = "no odometry (tf " + settings_.odom_frame_id + " -> " + settings_.base_frame_id +
               ") at the scan: " + why + "; check that odometry is published on /tf and covers the scans' stamps";
    }
    return pose;
  }
  // Like a tf lookup, wait up to tf_timeout of wall time for odometry at the scan's stamp: on a loaded machine the
  // scan may be handled before the odometry sent just before it (another connection).
  std::unique_lock<std::mutex> lock(mutex_);
  odometry_cv_.wait_for(lock, std::chrono::duration<double>(settings_.tf_timeout),
                        [&] { return time_jump_pending_ || (!odometry_.empty() && odometry_.back().stamp >= stamp); });
  if (odometry_.empty()) {
    *error = "no odometry on " + settings_.odom_topic + " yet (is it published?)";
    return std::nullopt;
  }
  for (std::size_t i = 1; i < odometry_.size(); ++i) {
    const TimedOdometry& a = odometry_[i - 1];
    const TimedOdometry& b = odometry_[i];
    if (a.stamp <= stamp && stamp <= b.stamp) {
      const double span = seconds_between(a.stamp, b.stamp);
      const double f = span > 0.0 ? seconds_between(a.stamp, stamp) / span : 0.0;
      return interpolate_pose(a.pose, b.pose, f);
    }
  }
  const TimedOdometry& last = odometry_.back();
  const double behind = seconds_between(last.stamp, stamp);
  if (std::abs(behind) <= settings_.tf_timeout) return last.pose;
  char buf[200];
  std::snprintf(buf, sizeof(buf), "no odometry on %s at the scan (%.3f s): the messages span %.3f..%.3f s%s",
                settings_.odom_topic.c_str(), stamp.seconds(), odometry_.front().stamp.seconds(), last.stamp.seconds(),
                behind > 0 ? " (odometry stalled or late)" : " (scan older than them)");
  *error = buf;
  return std::nullopt;
}

std::optional<Pose> LocalizationCore::extrinsic(const std::string& frame, std::string* error, std::string* source) {
  // Extrinsics are rigid: the latest transform serves every stamp. With the parameter there is no waiting for tf:
  // the parameter is for robots that have none.
  const auto given = settings_.sensor_extrinsics.find(frame);
  if (given == settings_.sensor_extrinsics.end() || tf_.can_lookup(settings_.base_frame_id, frame, std::nullopt)) {
    if (source) *source = "tf";
    return tf_.lookup(settings_.base_frame_id, frame, std::nullopt, settings_.tf_timeout, error);
  }
  if (source) *source = out_.parameter_name("sensor_extrinsics." + frame);
  return given->second;
}

bool LocalizationCore::add_cloud(const CloudMsg& msg, std::vector<Eigen::Vector3f>& points, bool primary,
                                 std::string* error) {
  const std::string& frame = msg.header.frame_id;
  std::string why, source;
  const std::optional<Pose> base_T_cloud = extrinsic(frame, &why, &source);
  if (!base_T_cloud) {
    *error = "no transform " + settings_.base_frame_id + " -> " + frame + " (the LiDAR's mounting): " + why +
             ". Publish it latched on /tf_static (robot_state_publisher, or " +
             out_.static_transform_command(settings_.base_frame_id, frame) + "), give it as " +
             out_.parameter_name("sensor_extrinsics." + frame) + ": [x, y, z, roll, pitch, yaw], or check " +
             out_.parameter_name("base_frame_id") + " and the clouds' header.frame_id; retried with every scan";
    return false;
  }
  PointCloud cloud = decode_pointcloud2(msg.layout, msg.data, msg.size, nullptr, "PointCloud2 in frame " + frame);
  const Eigen::Isometry3f t = base_T_cloud->cast<float>();
  for (const Eigen::Vector3f& p : cloud.points) points.push_back(t * p);
  if (primary) {
    last_sensor_scan_ = std::move(cloud.points);  // the cloud is not used after this
    last_base_T_sensor_ = *base_T_cloud;
    last_extrinsic_source_ = source;
  }
  return true;
}

void LocalizationCore::process(const CloudMsg& primary, Stamp stamp, const std::vector<CloudMsg>& others) {
  bool restart = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::swap(restart, time_jump_pending_);
    if (!restart && last_stamp_ && stamp <= *last_stamp_) {
      char buf[160];
      std::snprintf(buf, sizeof(buf), "scan stamped %.6f s, not after the last one (%.6f s)", stamp.seconds(),
                    last_stamp_->seconds());
      reject_locked(buf);
      return;
    }
  }
  if (restart) restart_after_time_jump();
  std::vector<Eigen::Vector3f>& points = scan_points_;  // reused: no allocation per scan once grown
  points.clear();
  std::string problem;
  try {
    if (!add_cloud(primary, points, true, &problem)) {
      ++counters_.failed;
      publish_problem(stamp, problem);
      return;
    }
    for (const CloudMsg& o : others) add_cloud(o, points, false, &problem);
  } catch (const Error& e) {
    ++counters_.failed;
    publish_problem(stamp, std::string("scan skipped: ") + e.what());
    return;
  }
  // Requests take effect at this scan, after its clouds are read (a planar initial pose is completed from it).
  apply_requests(stamp);
  const std::optional<Pose> odom_T_base = odometry_at(stamp, &problem);
  if (!odom_T_base && localizer_->options().filter.motion.type == MotionModelType::kOdometry) {
    ++counters_.failed;
    publish_problem(stamp, problem);  // no pose invented
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const ImuSample& s : imu_) {
      try {
        localizer_->add_imu(s);
      } catch (const Error& e) {
        reject_locked(std::string("IMU sample: ") + e.what());
      }
    }
    imu_.clear();
  }
  const auto t0 = std::chrono::steady_clock::now();
  const ScanRecord* record = nullptr;
  try {
    record = &localizer_->process(stamp.seconds(), points, odom_T_base);
  } catch (const Error& e) {
    ++counters_.failed;
    publish_problem(stamp, std::string("scan skipped: ") + e.what());
    return;
  }
  estimate_valid_ = true;
  const double update_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ++counters_.processed;
  if (last_stamp_ && stamp > *last_stamp_) {
    const double dt = seconds_between(*last_stamp_, stamp);
    scan_period_ = scan_period_ > 0.0 ? 0.9 * scan_period_ + 0.1 * dt : dt;
  }
  last_stamp_ = stamp;
  if (scan_period_ > 0.0 && update_ms > 1000.0 * scan_period_) ++counters_.late;
  follow_last_pose(*record);
  publish(stamp, *record, update_ms);
  if (odom_T_base) broadcast_map_to_odom(stamp, record->step.estimate.pose, *odom_T_base);
}

void LocalizationCore::broadcast_map_to_odom(Stamp stamp, const Pose& map_T_base, const Pose& odom_T_base) {
  const Pose map_T_odom = map_T_base * odom_T_base.inverse();
  if (!settings_.tf_broadcast || !map_T_odom.matrix().allFinite()) return;
  TransformOut t;
  t.stamp = {stamp.ns + static_cast<std::int64_t>(settings_.transform_tolerance * 1e9)};
  t.parent = settings_.global_frame_id;
  t.child = settings_.odom_frame_id;
  t.pose = map_T_odom;
  out_.send_transform(t);
}

void LocalizationCore::follow_last_pose(const ScanRecord& record) {
  if (!last_pose_) return;
  try {
    if (const std::string note = last_pose_->follow(*localizer_, record); !note.empty()) {
      out_.log(LogLevel::kWarn, "tsdf_mcl: " + note);
    }
  } catch (const Error& e) {
    log_throttled("last_pose_file", 60.0, LogLevel::kWarn, std::string("tsdf_mcl: ") + e.what());
  }
}

}  // namespace tsdf_mcl::node
