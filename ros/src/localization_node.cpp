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

// A number parameter within [min, max]; `integral` ones must be whole. Absent: `value`. Anything else (text, NaN,
// out of range) is an Error naming the parameter and the range, never a silent default.
double number_param(const ros::NodeHandle& pnh, const std::string& name, double value, double min, double max,
                    bool integral) {
  XmlRpc::XmlRpcValue v;
  if (!pnh.getParam(name, v)) return value;
  char range[96];
  std::snprintf(range, sizeof(range), "%s in %g..%g", integral ? "a whole number" : "a number", min, max);
  double x = 0.0;
  if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) {
    x = static_cast<int>(v);
  } else if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) {
    x = static_cast<double>(v);
  } else {
    std::string text;
    try {
      text = to_text(v);
    } catch (const Error&) {
      text = "(not a number)";
    }
    throw Error("~" + name + " must be " + range + ", got '" + one_line(text) + "'");
  }
  if (!(x >= min && x <= max) || (integral && x != std::floor(x))) {
    char got[64];
    std::snprintf(got, sizeof(got), "%.17g", x);
    throw Error("~" + name + " must be " + range + ", got " + got);
  }
  return x;
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

// ~sensor_extrinsics: {frame: [x, y, z, roll, pitch, yaw]} (m; radians or with a unit, "90deg"), base_frame_id ->
// frame. A value may also be text ("0 0 0.5 0 0 90deg"): `_sensor_extrinsics/lidar:=...` on the command line gives
// text, as roscpp reads no lists there.
std::map<std::string, Pose> sensor_extrinsics_of(const ros::NodeHandle& pnh) {
  std::map<std::string, Pose> extrinsics;
  XmlRpc::XmlRpcValue v;
  if (!pnh.getParam("sensor_extrinsics", v)) return extrinsics;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
    throw Error(
        "~sensor_extrinsics must map frame names to [x, y, z, roll, pitch, yaw], e.g. {lidar: [0, 0, 0.5, 0, "
        "0, 0]}");
  }
  for (auto& [frame, value] : v) {
    const std::string what = "~sensor_extrinsics/" + frame;
    std::string text;
    try {
      text = to_text(value);
    } catch (const Error& e) {
      throw Error(what + ": " + e.what());
    }
    std::vector<std::string> items;
    std::string item;
    for (const char c : text + " ") {
      if (c == ' ' || c == ',' || c == '[' || c == ']' || c == '\t') {
        if (!item.empty()) items.push_back(item);
        item.clear();
      } else {
        item += c;
      }
    }
    if (items.size() != 6) {
      throw Error(what + " must be x, y, z, roll, pitch, yaw (m, and radians or e.g. 90deg), got '" + one_line(text) +
                  "'");
    }
    double p[6];
    const char* names[] = {"x", "y", "z", "roll", "pitch", "yaw"};
    for (int i = 0; i < 6; ++i) {
      const std::string name = what + "'s " + names[i];
      if (i >= 3) {
        p[i] = parse_angle(items[i], name, 2.0 * M_PI);
        continue;
      }
      // A mounting offset beyond 100 m is a typo (millimetres for metres), not a robot.
      char* end = nullptr;
      p[i] = std::strtod(items[i].c_str(), &end);
      if (end != items[i].c_str() + items[i].size() || !(std::abs(p[i]) <= 100.0)) {
        throw Error(name + " must be a number in -100..100 m, got '" + one_line(items[i]) + "'");
      }
    }
    extrinsics[frame] = pose_from_xyz_rpy(p[0], p[1], p[2], p[3], p[4], p[5]);
  }
  return extrinsics;
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
  s.transform_tolerance = number_param(pnh, "transform_tolerance", s.transform_tolerance, 0.0, 60.0, false);
  s.tf_timeout = number_param(pnh, "tf_timeout", s.tf_timeout, 0.0, 10.0, false);
  s.merge_window = number_param(pnh, "merge_window", s.merge_window, 0.0, 10.0, false);
  pnh.param("tf_broadcast", s.tf_broadcast, s.tf_broadcast);
  s.max_published_particles =
      static_cast<int>(number_param(pnh, "max_published_particles", s.max_published_particles, 0, 1e7, true));
  s.map_cloud_points = static_cast<int>(number_param(pnh, "map_cloud_points", s.map_cloud_points, 0, 1e8, true));
  s.sensor_extrinsics = sensor_extrinsics_of(pnh);
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
    if (key.rfind("sensor_extrinsics/", 0) == 0) continue;  // one per frame, any frame name
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
  localizer_->reset_to(pose);
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

void LocalizationNode::publish_problem(const ros::Time& stamp, const std::string& problem) {
  ROS_WARN_THROTTLE(5.0, "tsdf_mcl: scan at %.3f not used: %s", stamp.toSec(), problem.c_str());
  diagnostic_msgs::DiagnosticStatus status;
  status.name = "tsdf_mcl: localization";
  status.hardware_id = settings_.base_frame_id;
  status.level = diagnostic_msgs::DiagnosticStatus::ERROR;
  status.message = one_line(problem);
  auto add = [&status](const std::string& key, const std::string& value) {
    diagnostic_msgs::KeyValue kv;
    kv.key = key;
    kv.value = value;
    status.values.push_back(kv);
  };
  add("state", "no scan used");
  add("problem", status.message);
  add("processed_scans", std::to_string(processed_));
  add("failed_scans", std::to_string(failed_));
  add_rejections(add);
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = stamp;
  array.status.push_back(status);
  diagnostics_pub_.publish(array);
}

template <typename Add>
void LocalizationNode::add_rejections(const Add& add) {
  std::lock_guard<std::mutex> lock(mutex_);
  add("rejected_messages", std::to_string(rejected_));
  add("last_rejection", last_rejection_);
  add("time_jumps", std::to_string(time_jumps_));
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
  add_rejections(add);
  if (record) {
    add("particles", std::to_string(record->step.particles));
    add("inlier_ratio", std::to_string(record->step.estimate.inlier_ratio));
    add("map_coverage", std::to_string(record->step.estimate.coverage));
  }
  add("extrinsic", last_extrinsic_source_);  // tf, or ~sensor_extrinsics/<frame>
  add("backend", localizer_->evaluator().backend());
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = stamp;
  array.status.push_back(status);
  diagnostics_pub_.publish(array);
}

}  // namespace tsdf_mcl::ros_node
