#include "localization_node.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <tf2/exceptions.h>

#include "ros_conversions.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "tsdf_mcl/localizer/planar_pose.hpp"
#include "tsdf_mcl/io/transform_tree.hpp"

namespace tsdf_mcl::ros_node {
namespace {

constexpr double kOdometryKeepSeconds = 10.0;
constexpr double kImuKeepSeconds = 2.0;

std::string to_text(const XmlRpc::XmlRpcValue& v) {
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(v) ? "true" : "false";
    case XmlRpc::XmlRpcValue::TypeInt:
      return std::to_string(static_cast<int>(v));
    case XmlRpc::XmlRpcValue::TypeDouble: {
      std::ostringstream out;
      out.precision(17);
      out << static_cast<double>(v);
      return out.str();
    }
    case XmlRpc::XmlRpcValue::TypeString:
      return static_cast<std::string>(v);
    case XmlRpc::XmlRpcValue::TypeArray: {
      std::string joined;
      for (int i = 0; i < v.size(); ++i) joined += (i ? "," : "") + to_text(v[i]);
      return joined;
    }
    default:
      throw Error("parameter of a type the node cannot read (struct, binary or date)");
  }
}

// A schema name as a key of the private namespace: "initial_pose.x" is ~initial_pose/x.
std::string ros_key(const std::string& name) {
  std::string key = name;
  for (char& c : key) c = c == '.' ? '/' : c;
  return key;
}

// Every name of the library's parameter schema (localizer_parameters.hpp) and its amcl aliases.
std::vector<std::string> schema_names() {
  std::vector<std::string> names;
  for (const ParameterSpec& spec : localizer_parameter_specs()) names.push_back(spec.name);
  for (const ParameterAlias& alias : localizer_parameter_aliases()) names.push_back(alias.alias);
  return names;
}

// The filter parameters, by the library schema's names (nav2 AMCL's where they exist, ROS 1 amcl's as aliases),
// from the private namespace, with the schema's validation: the node is a plain adapter over it.
LocalizerOptions localizer_options_of(const ros::NodeHandle& pnh) {
  std::map<std::string, std::string> values;
  for (const std::string& name : schema_names()) {
    XmlRpc::XmlRpcValue value;
    if (!pnh.getParam(ros_key(name), value)) continue;
    try {
      values[name] = to_text(value);
    } catch (const Error& e) {
      throw Error("~" + ros_key(name) + ": " + e.what());
    }
  }
  try {
    return localizer_options_from(values);
  } catch (const Error& e) {
    throw Error(std::string("parameter ~") + e.what());
  }
}

NodeSettings settings_from(const ros::NodeHandle& pnh) {
  NodeSettings s;
  if (!pnh.getParam("map_file", s.map_file) || s.map_file.empty()) {
    throw Error("~map_file is not set (a TSDF map from tsdf-mcl build-map)");
  }
  pnh.param("global_frame_id", s.global_frame_id, s.global_frame_id);
  pnh.param("odom_frame_id", s.odom_frame_id, s.odom_frame_id);
  pnh.param("base_frame_id", s.base_frame_id, s.base_frame_id);
  XmlRpc::XmlRpcValue topics;
  if (pnh.getParam("point_topics", topics)) {
    s.point_topics.clear();
    std::string joined = to_text(topics);
    std::stringstream in(joined);
    for (std::string t; std::getline(in, t, ',');)
      if (!t.empty()) s.point_topics.push_back(t);
    if (s.point_topics.empty()) throw Error("~point_topics names no topic");
  }
  pnh.param("odom_topic", s.odom_topic, s.odom_topic);
  pnh.param("imu_topic", s.imu_topic, s.imu_topic);
  pnh.param("transform_tolerance", s.transform_tolerance, s.transform_tolerance);
  pnh.param("tf_timeout", s.tf_timeout, s.tf_timeout);
  pnh.param("merge_window", s.merge_window, s.merge_window);
  pnh.param("tf_broadcast", s.tf_broadcast, s.tf_broadcast);
  pnh.param("max_published_particles", s.max_published_particles, s.max_published_particles);
  pnh.param("map_cloud_points", s.map_cloud_points, s.map_cloud_points);
  if (!(s.transform_tolerance >= 0.0) || !(s.tf_timeout >= 0.0) || !(s.merge_window >= 0.0)) {
    throw Error("~transform_tolerance, ~tf_timeout and ~merge_window must not be negative");
  }
  if (s.max_published_particles < 0 || s.map_cloud_points < 0) {
    throw Error("~max_published_particles and ~map_cloud_points must not be negative");
  }
  return s;
}

// A misspelt parameter would otherwise be silently ignored.
void warn_unknown_parameters(const ros::NodeHandle& pnh) {
  std::vector<std::string> known = {"map_file",        "global_frame_id", "odom_frame_id", "base_frame_id",
                                    "point_topics",    "odom_topic",      "imu_topic",     "transform_tolerance",
                                    "tf_timeout",      "merge_window",    "tf_broadcast",  "max_published_particles",
                                    "map_cloud_points"};
  for (const std::string& name : schema_names()) known.push_back(ros_key(name));
  std::vector<std::string> names;
  if (!ros::param::getParamNames(names)) return;
  const std::string ns = pnh.getNamespace() + "/";
  for (const std::string& name : names) {
    if (name.rfind(ns, 0) != 0) continue;
    const std::string key = name.substr(ns.size());
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      ROS_WARN("tsdf_mcl: unknown parameter %s ignored%s (see tsdf-mcl localize --help and docs/ros.md)", name.c_str(),
               did_you_mean(key, known, "~").c_str());
    }
  }
}

double yaw_of(const Pose& p) {
  const Eigen::Vector3d x = p.rotation().col(0);
  return std::atan2(x.y(), x.x());
}

}  // namespace

LocalizationNode::LocalizationNode(ros::NodeHandle nh, ros::NodeHandle private_nh)
    : nh_(nh), private_nh_(private_nh), tf_listener_(tf_buffer_) {
  settings_ = settings_from(private_nh_);
  warn_unknown_parameters(private_nh_);
  const LocalizerOptions options = localizer_options_of(private_nh_);
  map_ = load_map(settings_.map_file);
  localizer_ = std::make_unique<Localizer>(map_, options);
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

void LocalizationNode::on_cloud(std::size_t topic, const sensor_msgs::PointCloud2ConstPtr& msg) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (topic == 0 && latest_[0].fresh) ++skipped_;  // the filter is still busy with an older scan
    latest_[topic] = {msg, true};
  }
  if (topic == 0) cv_.notify_one();
}

void LocalizationNode::on_odometry(const nav_msgs::OdometryConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  odometry_.push_back(*msg);
  while (!odometry_.empty() && (msg->header.stamp - odometry_.front().header.stamp).toSec() > kOdometryKeepSeconds)
    odometry_.pop_front();
}

void LocalizationNode::on_imu(const sensor_msgs::ImuConstPtr& msg) {
  // Specific force in the base frame: the IMU's mounting rotation from tf (the filter's sensor is the base).
  std::optional<Pose> base_T_imu = lookup(settings_.base_frame_id, msg->header.frame_id, ros::Time(0));
  if (!base_T_imu) return;
  ImuSample s;
  s.time = msg->header.stamp.toSec();
  s.acceleration = base_T_imu->rotation() *
                   Eigen::Vector3d(msg->linear_acceleration.x, msg->linear_acceleration.y, msg->linear_acceleration.z);
  std::lock_guard<std::mutex> lock(mutex_);
  imu_.push_back(s);
  while (!imu_.empty() && s.time - imu_.front().time > kImuKeepSeconds) imu_.pop_front();
}

void LocalizationNode::on_initial_pose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& msg) {
  if (!msg->header.frame_id.empty() && msg->header.frame_id != settings_.global_frame_id) {
    ROS_WARN("tsdf_mcl: /initialpose in frame %s ignored (expected %s)", msg->header.frame_id.c_str(),
             settings_.global_frame_id.c_str());
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
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
        processed_ > 0 ? std::optional<double>(localizer_->estimate().pose.translation().z()) : std::nullopt;
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
  localizer_->reset_to(pose);
}

std::optional<Pose> LocalizationNode::lookup(const std::string& target, const std::string& source,
                                             const ros::Time& stamp) {
  try {
    const geometry_msgs::TransformStamped t =
        tf_buffer_.lookupTransform(target, source, stamp, ros::Duration(settings_.tf_timeout));
    return pose_from_msg(t.transform);
  } catch (const tf2::TransformException& e) {
    ROS_WARN_THROTTLE(5.0, "tsdf_mcl: no transform %s -> %s at %.3f: %s", target.c_str(), source.c_str(), stamp.toSec(),
                      e.what());
    return std::nullopt;
  }
}

std::optional<Pose> LocalizationNode::odometry_at(const ros::Time& stamp) {
  if (settings_.odom_topic.empty()) return lookup(settings_.odom_frame_id, settings_.base_frame_id, stamp);
  std::lock_guard<std::mutex> lock(mutex_);
  if (odometry_.empty()) return std::nullopt;
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
  if (std::abs((stamp - last.header.stamp).toSec()) <= settings_.tf_timeout) return pose_from_msg(last.pose.pose);
  return std::nullopt;
}

bool LocalizationNode::add_cloud(const sensor_msgs::PointCloud2& msg, std::vector<Eigen::Vector3f>& points,
                                 bool primary) {
  // Extrinsics are rigid: the latest transform serves every stamp.
  const std::optional<Pose> base_T_cloud = lookup(settings_.base_frame_id, msg.header.frame_id, ros::Time(0));
  if (!base_T_cloud) return false;
  PointCloud cloud = cloud_from_msg(msg, "PointCloud2 in frame " + msg.header.frame_id);
  const Eigen::Isometry3f t = base_T_cloud->cast<float>();
  for (const Eigen::Vector3f& p : cloud.points) points.push_back(t * p);
  if (primary) {
    last_sensor_scan_ = std::move(cloud.points);  // the cloud is not used after this
    last_base_T_sensor_ = *base_T_cloud;
  }
  return true;
}

void LocalizationNode::process(const sensor_msgs::PointCloud2ConstPtr& primary,
                               const std::vector<sensor_msgs::PointCloud2ConstPtr>& others) {
  const ros::Time stamp = primary->header.stamp;
  std::vector<Eigen::Vector3f>& points = scan_points_;  // reused: no allocation per scan once grown
  points.clear();
  try {
    if (!add_cloud(*primary, points, true)) {
      ++failed_;
      return;
    }
    for (const auto& o : others) add_cloud(*o, points, false);
  } catch (const Error& e) {
    ROS_WARN_THROTTLE(5.0, "tsdf_mcl: scan skipped: %s", e.what());
    ++failed_;
    return;
  }
  // Requests take effect at this scan, after its clouds are read (a planar initial pose is completed from it).
  apply_requests(stamp);
  const std::optional<Pose> odom_T_base = odometry_at(stamp);
  if (!odom_T_base && localizer_->options().filter.motion.type == MotionModelType::kOdometry) {
    ++failed_;
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (const ImuSample& s : imu_) localizer_->add_imu(s);
    imu_.clear();
  }
  const auto t0 = std::chrono::steady_clock::now();
  const ScanRecord* record = nullptr;
  try {
    record = &localizer_->process(stamp.toSec(), points, odom_T_base);
  } catch (const Error& e) {
    ROS_WARN_THROTTLE(5.0, "tsdf_mcl: scan skipped: %s", e.what());
    ++failed_;
    return;
  }
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
  if (settings_.tf_broadcast) {
    geometry_msgs::TransformStamped t;
    t.header.stamp = stamp + ros::Duration(settings_.transform_tolerance);
    t.header.frame_id = settings_.global_frame_id;
    t.child_frame_id = settings_.odom_frame_id;
    t.transform = transform_from_pose(record->step.estimate.pose * odom_T_base->inverse());
    tf_broadcaster_.sendTransform(t);
  }
}

void LocalizationNode::publish(const ros::Time& stamp, const ScanRecord& record, const Pose& /*odom_T_base*/,
                               double update_ms) {
  const PoseEstimate& e = record.step.estimate;
  geometry_msgs::PoseWithCovarianceStamped pose;
  pose.header.stamp = stamp;
  pose.header.frame_id = settings_.global_frame_id;
  pose.pose.pose = msg_from_pose(e.pose);
  pose.pose.covariance = ros_covariance(e.pose, e.covariance);
  pose_pub_.publish(pose);

  geometry_msgs::PoseArray hypotheses;
  hypotheses.header = pose.header;
  for (const Hypothesis& h : e.hypotheses) hypotheses.poses.push_back(msg_from_pose(h.pose));
  hypotheses_pub_.publish(hypotheses);

  if (record.step.updated && particles_pub_.getNumSubscribers() > 0 && settings_.max_published_particles > 0) {
    const ParticleSnapshot snapshot = localizer_->snapshot();
    geometry_msgs::PoseArray cloud;
    cloud.header = pose.header;
    const std::size_t n = snapshot.particles.size();
    const std::size_t every = std::max<std::size_t>(
        1, (n + settings_.max_published_particles - 1) / static_cast<std::size_t>(settings_.max_published_particles));
    for (std::size_t i = 0; i < n; i += every) {
      const auto& p = snapshot.particles[i];
      geometry_msgs::Pose m;
      m.position.x = p.position.x();
      m.position.y = p.position.y();
      m.position.z = p.position.z();
      m.orientation.x = p.orientation.x();
      m.orientation.y = p.orientation.y();
      m.orientation.z = p.orientation.z();
      m.orientation.w = p.orientation.w();
      cloud.poses.push_back(m);
    }
    particles_pub_.publish(cloud);
  }
  publish_status(stamp, &record, update_ms);
}

void LocalizationNode::publish_status(const ros::Time& stamp, const ScanRecord* record, double update_ms) {
  diagnostic_msgs::DiagnosticStatus status;
  status.name = "tsdf_mcl: localization";
  status.hardware_id = settings_.base_frame_id;
  std::string state = "searching";
  std::string hypotheses;
  if (record) {
    // The library classifies (track_state.hpp); the node only reports it.
    const PoseEstimate& e = record->step.estimate;
    state = to_string(record->step.state);
    char buf[160];
    for (std::size_t i = 0; i < e.hypotheses.size() && i < 5; ++i) {
      const Hypothesis& h = e.hypotheses[i];
      std::snprintf(buf, sizeof(buf), "%s%.0f %% at (%.2f, %.2f, %.2f, yaw %.0f deg)", i ? "; " : "", 100.0 * h.weight,
                    h.pose.translation().x(), h.pose.translation().y(), h.pose.translation().z(),
                    yaw_of(h.pose) * 180.0 / M_PI);
      hypotheses += buf;
    }
  }
  status.level = state == "converged" ? diagnostic_msgs::DiagnosticStatus::OK
                 : state == "lost"    ? diagnostic_msgs::DiagnosticStatus::ERROR
                                      : diagnostic_msgs::DiagnosticStatus::WARN;
  status.message = state;
  auto add = [&status](const std::string& key, const std::string& value) {
    diagnostic_msgs::KeyValue kv;
    kv.key = key;
    kv.value = value;
    status.values.push_back(kv);
  };
  add("state", state);
  add("hypotheses", hypotheses);
  add("update_ms", std::to_string(update_ms));
  add("scan_period_ms", std::to_string(1000.0 * scan_period_));
  add("processed_scans", std::to_string(processed_));
  std::size_t skipped = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    skipped = skipped_;
  }
  add("skipped_scans", std::to_string(skipped));
  add("late_updates", std::to_string(late_));
  add("failed_scans", std::to_string(failed_));
  if (record) {
    add("particles", std::to_string(record->step.particles));
    add("inlier_ratio", std::to_string(record->step.estimate.inlier_ratio));
    add("map_coverage", std::to_string(record->step.estimate.coverage));
  }
  add("backend", localizer_->evaluator().backend());
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = stamp;
  array.status.push_back(status);
  diagnostics_pub_.publish(array);
}

}  // namespace tsdf_mcl::ros_node
