// The node's setup (parameters, map, publishers, subscriptions), its run loop and a scan's way through tf and the
// filter; the callbacks are in node_messages.cpp, what it publishes in node_diagnostics.cpp.
#include "localization_node.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>
#include <thread>
#include <utility>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <tf2/exceptions.h>
#include <boost/function.hpp>

#include "node_parameters.hpp"
#include "ros_conversions.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"
#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/io/transform_tree.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"
#include "tsdf_mcl/localizer/planar_pose.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "tsdf_mcl/map/map_surface.hpp"

namespace tsdf_mcl::ros_node {

LocalizationNode::LocalizationNode(ros::NodeHandle nh, ros::NodeHandle private_nh) : nh_(nh), private_nh_(private_nh) {
  settings_ = settings_from(private_nh_);
  warn_unknown_parameters(private_nh_);
  options_ = localizer_options_of(private_nh_);
  map_ = load_map(settings_.map_file);
  localizer_ = std::make_unique<Localizer>(map_, options_);
  ROS_INFO("tsdf_mcl: map %s, %s", settings_.map_file.c_str(), localizer_->backend_note().c_str());

  pose_pub_ = nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("amcl_pose", 2, true);
  particles_pub_ = nh_.advertise<geometry_msgs::PoseArray>("particlecloud", 2);
  hypotheses_pub_ = private_nh_.advertise<geometry_msgs::PoseArray>("hypotheses", 2);
  map_cloud_pub_ = private_nh_.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, true);
  diagnostics_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("diagnostics", 10);

  sensor_msgs::PointCloud2 surface =
      msg_from_cloud(map_surface(map_, static_cast<std::size_t>(settings_.map_cloud_points)));
  surface.header.frame_id = settings_.global_frame_id;
  surface.header.stamp = ros::Time::now();
  map_cloud_pub_.publish(surface);

  // tf on a queue and thread of its own, as tf2_ros::TransformListener does (on_imu waits for tf on the main
  // one), but through on_tf, which keeps bad stamps and poses away from tf2 and sees time going back.
  tf_buffer_.setUsingDedicatedThread(true);  // lookups may wait for tf: its thread fills the buffer meanwhile
  ros::NodeHandle tf_nh;
  tf_nh.setCallbackQueue(&tf_queue_);
  for (const bool is_static : {false, true}) {
    const boost::function<void(const ros::MessageEvent<tf2_msgs::TFMessage const>&)> callback =
        [this, is_static](const ros::MessageEvent<tf2_msgs::TFMessage const>& e) { on_tf(e, is_static); };
    tf_subscribers_.push_back(tf_nh.subscribe<tf2_msgs::TFMessage>(is_static ? "/tf_static" : "/tf", 100, callback));
  }
  tf_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &tf_queue_);
  tf_spinner_->start();

  latest_.resize(settings_.point_topics.size());
  for (std::size_t i = 0; i < settings_.point_topics.size(); ++i) {
    subscribers_.push_back(nh_.subscribe<sensor_msgs::PointCloud2>(
        settings_.point_topics[i], 2, [this, i](const sensor_msgs::PointCloud2ConstPtr& m) { on_cloud(i, m); }));
  }
  if (!settings_.odom_topic.empty()) {
    subscribers_.push_back(nh_.subscribe(settings_.odom_topic, 100, &LocalizationNode::on_odometry, this));
  }
  if (!settings_.imu_topic.empty()) {
    subscribers_.push_back(nh_.subscribe(settings_.imu_topic, 400, &LocalizationNode::on_imu, this));
  }
  subscribers_.push_back(nh_.subscribe("initialpose", 2, &LocalizationNode::on_initial_pose, this));
  services_.push_back(nh_.advertiseService("global_localization", &LocalizationNode::on_global_localization, this));
  services_.push_back(nh_.advertiseService("request_nomotion_update", &LocalizationNode::on_nomotion_update, this));
}

LocalizationNode::~LocalizationNode() {
  if (tf_spinner_) tf_spinner_->stop();
}

void LocalizationNode::run() {
  while (ros::ok()) {
    sensor_msgs::PointCloud2ConstPtr primary;
    std::vector<sensor_msgs::PointCloud2ConstPtr> others;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      cv_.wait_for(lock, std::chrono::milliseconds(100), [this] { return latest_[0].fresh; });
      if (!latest_[0].fresh) continue;
      primary = latest_[0].msg;
      latest_[0].fresh = false;
      for (std::size_t k = 1; k < latest_.size(); ++k) {
        if (latest_[k].msg &&
            std::abs((latest_[k].msg->header.stamp - primary->header.stamp).toSec()) <= settings_.merge_window)
          others.push_back(latest_[k].msg);
      }
    }
    process(primary, others);
  }
}

void LocalizationNode::apply_requests(const ros::Time& stamp) {
  std::optional<geometry_msgs::PoseWithCovarianceStamped> pose_request;
  bool global = false, nomotion = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::swap(pose_request, initial_pose_request_);
    std::swap(global, global_request_);
    std::swap(nomotion, nomotion_request_);
  }
  if (global) localizer_->reset_global();
  if (nomotion) localizer_->request_update();
  if (!pose_request) return;
  Pose pose = pose_from_msg(pose_request->pose.pose);
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
      ROS_WARN(
          "tsdf_mcl: /initialpose left z, roll and pitch 0 and the map or the last scan shows no floor there: "
          "using them as given");
    }
  }
  const Eigen::Vector3d t = pose.translation();
  ROS_INFO("tsdf_mcl: initial pose %.2f %.2f %.2f, yaw %.1f deg%s (stamp %.3f)", t.x(), t.y(), t.z(),
           yaw_of(pose) * 180.0 / M_PI, planar ? " (z, roll, pitch from the map)" : "", stamp.toSec());
  try {
    localizer_->reset_to(pose);  // a pose outside the map is refused (map_extent_checks.hpp)
  } catch (const Error& e) {
    ROS_WARN("tsdf_mcl: /initialpose refused: %s", one_line(e.what()).c_str());
  }
}

std::optional<Pose> LocalizationNode::lookup(const std::string& target, const std::string& source,
                                             const ros::Time& stamp, std::string* error) {
  // Waits up to tf_timeout of wall time for the transform, polling: tf2's own wait runs on ROS time, which stands
  // still when a bag ends and, when it jumps back, waits until it is reached again (for ever, after the last
  // play). A time jump ends the wait.
  const tf2::BufferCore& core = tf_buffer_;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(settings_.tf_timeout);
  while (!core.canTransform(target, source, stamp, nullptr) && std::chrono::steady_clock::now() < deadline) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (time_jump_pending_) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  try {
    const geometry_msgs::TransformStamped t = core.lookupTransform(target, source, stamp);
    return pose_from_msg(t.transform);
  } catch (const tf2::TransformException& e) {
    if (error) *error = one_line(e.what());
    ROS_WARN_THROTTLE(5.0, "tsdf_mcl: no transform %s -> %s at %.3f: %s", target.c_str(), source.c_str(), stamp.toSec(),
                      e.what());
    return std::nullopt;
  }
}

std::optional<Pose> LocalizationNode::odometry_at(const ros::Time& stamp, std::string* error) {
  if (settings_.odom_topic.empty()) {
    std::string why;
    const std::optional<Pose> pose = lookup(settings_.odom_frame_id, settings_.base_frame_id, stamp, &why);
    if (!pose) {
      *error = "no odometry (tf " + settings_.odom_frame_id + " -> " + settings_.base_frame_id +
               ") at the scan: " + why + "; check that odometry is published on /tf and covers the scans' stamps";
    }
    return pose;
  }
  // Like a tf lookup, wait up to tf_timeout of wall time for odometry at the scan's stamp: on a loaded machine the
  // scan may be handled before the odometry sent just before it (another connection).
  std::unique_lock<std::mutex> lock(mutex_);
  odometry_cv_.wait_for(lock, std::chrono::duration<double>(settings_.tf_timeout), [&] {
    return time_jump_pending_ || (!odometry_.empty() && odometry_.back().header.stamp >= stamp);
  });
  if (odometry_.empty()) {
    *error = "no odometry on " + settings_.odom_topic + " yet (is it published?)";
    return std::nullopt;
  }
  for (std::size_t i = 1; i < odometry_.size(); ++i) {
    const nav_msgs::Odometry& a = odometry_[i - 1];
    const nav_msgs::Odometry& b = odometry_[i];
    if (a.header.stamp <= stamp && stamp <= b.header.stamp) {
      const double span = (b.header.stamp - a.header.stamp).toSec();
      const double f = span > 0.0 ? (stamp - a.header.stamp).toSec() / span : 0.0;
      return interpolate_pose(pose_from_msg(a.pose.pose), pose_from_msg(b.pose.pose), f);
    }
  }
  const nav_msgs::Odometry& last = odometry_.back();
  const double behind = (stamp - last.header.stamp).toSec();
  if (std::abs(behind) <= settings_.tf_timeout) return pose_from_msg(last.pose.pose);
  char buf[200];
  std::snprintf(buf, sizeof(buf), "no odometry on %s at the scan (%.3f s): the messages span %.3f..%.3f s%s",
                settings_.odom_topic.c_str(), stamp.toSec(), odometry_.front().header.stamp.toSec(),
                last.header.stamp.toSec(), behind > 0 ? " (odometry stalled or late)" : " (scan older than them)");
  *error = buf;
  return std::nullopt;
}

std::optional<Pose> LocalizationNode::extrinsic(const std::string& frame, std::string* error, std::string* source) {
  // Extrinsics are rigid: the latest transform serves every stamp.
  const auto given = settings_.sensor_extrinsics.find(frame);
  const tf2::BufferCore& core = tf_buffer_;
  // With the parameter there is no waiting for tf: the parameter is for robots that have none.
  if (given == settings_.sensor_extrinsics.end() || core.canTransform(settings_.base_frame_id, frame, ros::Time(0))) {
    if (source) *source = "tf";
    return lookup(settings_.base_frame_id, frame, ros::Time(0), error);
  }
  if (source) *source = "~sensor_extrinsics/" + frame;
  return given->second;
}

bool LocalizationNode::add_cloud(const sensor_msgs::PointCloud2& msg, std::vector<Eigen::Vector3f>& points,
                                 bool primary, std::string* error) {
  std::string why, source;
  const std::optional<Pose> base_T_cloud = extrinsic(msg.header.frame_id, &why, &source);
  if (!base_T_cloud) {
    *error = "no transform " + settings_.base_frame_id + " -> " + msg.header.frame_id +
             " (the LiDAR's mounting): " + why +
             ". Publish it latched on /tf_static (robot_state_publisher, or rosrun tf2_ros "
             "static_transform_publisher X Y Z YAW PITCH ROLL " +
             settings_.base_frame_id + " " + msg.header.frame_id + "), give it as ~sensor_extrinsics/" +
             msg.header.frame_id +
             ": [x, y, z, roll, pitch, yaw], or check ~base_frame_id and the clouds' header.frame_id; retried with "
             "every scan";
    return false;
  }
  PointCloud cloud = cloud_from_msg(msg, "PointCloud2 in frame " + msg.header.frame_id);
  const Eigen::Isometry3f t = base_T_cloud->cast<float>();
  for (const Eigen::Vector3f& p : cloud.points) points.push_back(t * p);
  if (primary) {
    last_sensor_scan_ = std::move(cloud.points);  // the cloud is not used after this
    last_base_T_sensor_ = *base_T_cloud;
    last_extrinsic_source_ = source;
  }
  return true;
}

void LocalizationNode::process(const sensor_msgs::PointCloud2ConstPtr& primary,
                               const std::vector<sensor_msgs::PointCloud2ConstPtr>& others) {
  const ros::Time stamp = primary->header.stamp;
  bool restart = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    std::swap(restart, time_jump_pending_);
    if (!restart && last_stamp_ && stamp <= *last_stamp_) {
      reject_locked("scan stamped " + std::to_string(stamp.toSec()) + " s, not after the last one (" +
                    std::to_string(last_stamp_->toSec()) + " s)");
      return;
    }
  }
  if (restart) restart_after_time_jump();
  std::vector<Eigen::Vector3f>& points = scan_points_;  // reused: no allocation per scan once grown
  points.clear();
  std::string problem;
  try {
    if (!add_cloud(*primary, points, true, &problem)) {
      ++failed_;
      publish_problem(stamp, problem);
      return;
    }
    for (const auto& o : others) add_cloud(*o, points, false, &problem);
  } catch (const Error& e) {
    ++failed_;
    publish_problem(stamp, std::string("scan skipped: ") + e.what());
    return;
  }
  // Requests take effect at this scan, after its clouds are read (a planar initial pose is completed from it).
  apply_requests(stamp);
  const std::optional<Pose> odom_T_base = odometry_at(stamp, &problem);
  if (!odom_T_base && localizer_->options().filter.motion.type == MotionModelType::kOdometry) {
    ++failed_;
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
    record = &localizer_->process(stamp.toSec(), points, odom_T_base);
  } catch (const Error& e) {
    ++failed_;
    publish_problem(stamp, std::string("scan skipped: ") + e.what());
    return;
  }
  estimate_valid_ = true;
  const double update_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ++processed_;
  if (last_stamp_ && stamp > *last_stamp_) {
    const double dt = (stamp - *last_stamp_).toSec();
    scan_period_ = scan_period_ > 0.0 ? 0.9 * scan_period_ + 0.1 * dt : dt;
  }
  last_stamp_ = stamp;
  if (scan_period_ > 0.0 && update_ms > 1000.0 * scan_period_) ++late_;
  publish(stamp, *record, odom_T_base.value_or(Pose::Identity()), update_ms);
  if (!odom_T_base) return;
  const Pose map_T_odom = record->step.estimate.pose * odom_T_base->inverse();
  if (settings_.tf_broadcast && map_T_odom.matrix().allFinite()) {
    geometry_msgs::TransformStamped t;
    t.header.stamp = stamp + ros::Duration(settings_.transform_tolerance);
    t.header.frame_id = settings_.global_frame_id;
    t.child_frame_id = settings_.odom_frame_id;
    t.transform = transform_from_pose(map_T_odom);
    tf_broadcaster_.sendTransform(t);
  }
}

}  // namespace tsdf_mcl::ros_node
