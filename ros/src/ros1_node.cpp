#include "ros1_node.hpp"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <boost/function.hpp>

#include <algorithm>
#include <sstream>

#include "ros_conversions.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::ros_node {
namespace {

using node::ParameterValue;

ParameterValue scalar_value(const XmlRpc::XmlRpcValue& v) {
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return {ParameterValue::Type::kBool, static_cast<bool>(v) ? "true" : "false"};
    case XmlRpc::XmlRpcValue::TypeInt:
      return {ParameterValue::Type::kInteger, std::to_string(static_cast<int>(v))};
    case XmlRpc::XmlRpcValue::TypeDouble: {
      std::ostringstream out;
      out.precision(17);
      out << static_cast<double>(v);
      return {ParameterValue::Type::kDouble, out.str()};
    }
    case XmlRpc::XmlRpcValue::TypeString:
      return {ParameterValue::Type::kString, static_cast<std::string>(v)};
    case XmlRpc::XmlRpcValue::TypeArray: {
      std::string joined;
      for (int i = 0; i < v.size(); ++i) {
        const ParameterValue item = scalar_value(v[i]);
        if (item.type == ParameterValue::Type::kOther || item.type == ParameterValue::Type::kList) return item;
        joined += (i ? "," : "") + item.text;
      }
      return {ParameterValue::Type::kList, joined};
    }
    default:
      return {ParameterValue::Type::kOther, "parameter of a type the node cannot read (struct, binary or date)"};
  }
}

// Structs become dotted names: {initial_pose: {x: 1}} is initial_pose.x.
void flatten(const XmlRpc::XmlRpcValue& v, const std::string& name, node::NodeParameters& out) {
  if (v.getType() == XmlRpc::XmlRpcValue::TypeStruct) {
    for (auto it = v.begin(); it != v.end(); ++it) {
      flatten(it->second, name.empty() ? it->first : name + "." + it->first, out);
    }
    return;
  }
  out.values[name] = scalar_value(v);
}

}  // namespace

node::NodeParameters private_parameters(const ros::NodeHandle& pnh) {
  node::NodeParameters p;
  p.prefix = "~";
  p.separator = '/';
  XmlRpc::XmlRpcValue all;
  if (ros::param::get(pnh.getNamespace(), all)) flatten(all, "", p);
  return p;
}

Ros1Node::Ros1Node(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), parameters_(private_parameters(pnh_)) {
  const node::NodeSettings settings =
      node::settings_from(parameters_, node::default_last_pose_file(ros::this_node::getName()));
  const LocalizerOptions options = node::localizer_options_of(parameters_);
  for (const std::string& w : node::unknown_parameter_warnings(parameters_, {})) {
    ROS_WARN("tsdf_mcl: %s (see tsdf-mcl localize --help and docs/ros.md)", w.c_str());
  }
  pose_pub_ = nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("amcl_pose", 2, true);
  particles_pub_ = nh_.advertise<geometry_msgs::PoseArray>("particlecloud", 2);
  hypotheses_pub_ = pnh_.advertise<geometry_msgs::PoseArray>("hypotheses", 2);
  map_cloud_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("map_cloud", 1, true);
  diagnostics_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("diagnostics", 10);
  core_ = std::make_unique<node::LocalizationCore>(settings, options, *this);
  subscribe();
}

Ros1Node::~Ros1Node() {
  if (tf_spinner_) tf_spinner_->stop();
}

void Ros1Node::subscribe() {
  const node::NodeSettings& s = core_->settings();
  // tf on a queue and thread of its own, as tf2_ros::TransformListener does: the IMU callback waits for tf on the
  // main one.
  ros::NodeHandle tf_nh;
  tf_nh.setCallbackQueue(&tf_queue_);
  for (const bool is_static : {false, true}) {
    const boost::function<void(const tf2_msgs::TFMessageConstPtr&)> callback =
        [this, is_static](const tf2_msgs::TFMessageConstPtr& m) {
          std::vector<node::TransformMsg> transforms;
          for (const geometry_msgs::TransformStamped& t : m->transforms) {
            transforms.push_back({header_of(t.header), t.child_frame_id, raw_pose(t.transform)});
          }
          core_->on_tf(transforms, is_static);
        };
    subscribers_.push_back(tf_nh.subscribe<tf2_msgs::TFMessage>(is_static ? "/tf_static" : "/tf", 100, callback));
  }
  tf_spinner_ = std::make_unique<ros::AsyncSpinner>(1, &tf_queue_);
  tf_spinner_->start();

  for (std::size_t i = 0; i < s.point_topics.size(); ++i) {
    subscribers_.push_back(nh_.subscribe<sensor_msgs::PointCloud2>(
        s.point_topics[i], 2,
        [this, i](const sensor_msgs::PointCloud2ConstPtr& m) { core_->on_cloud(i, cloud_of(m)); }));
  }
  if (!s.odom_topic.empty()) {
    subscribers_.push_back(
        nh_.subscribe<nav_msgs::Odometry>(s.odom_topic, 100, [this](const nav_msgs::OdometryConstPtr& m) {
          core_->on_odometry({header_of(m->header), raw_pose(m->pose.pose)});
        }));
  }
  if (!s.imu_topic.empty()) {
    subscribers_.push_back(nh_.subscribe<sensor_msgs::Imu>(s.imu_topic, 400, [this](const sensor_msgs::ImuConstPtr& m) {
      const geometry_msgs::Vector3& a = m->linear_acceleration;
      core_->on_imu({header_of(m->header), {a.x, a.y, a.z}});
    }));
  }
  subscribers_.push_back(nh_.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "initialpose", 2, [this](const geometry_msgs::PoseWithCovarianceStampedConstPtr& m) {
        core_->on_initial_pose({header_of(m->header), raw_pose(m->pose.pose)});
      }));
  services_.push_back(nh_.advertiseService<std_srvs::Empty::Request, std_srvs::Empty::Response>(
      "global_localization", [this](std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
        core_->request_global_localization();
        return true;
      }));
  services_.push_back(nh_.advertiseService<std_srvs::Empty::Request, std_srvs::Empty::Response>(
      "request_nomotion_update", [this](std_srvs::Empty::Request&, std_srvs::Empty::Response&) {
        core_->request_nomotion_update();
        return true;
      }));
}

void Ros1Node::run() {
  core_->run([] { return ros::ok(); });
}

void Ros1Node::publish_pose(const node::PoseOut& pose) {
  geometry_msgs::PoseWithCovarianceStamped msg;
  msg.header.stamp = ros_time(pose.stamp);
  msg.header.frame_id = pose.frame_id;
  msg.pose.pose = msg_from_pose(pose.pose);
  std::copy(pose.covariance.begin(), pose.covariance.end(), msg.pose.covariance.begin());
  pose_pub_.publish(msg);
}

bool Ros1Node::particles_wanted() { return particles_pub_.getNumSubscribers() > 0; }

void Ros1Node::publish_particles(const node::PosesOut& particles) { particles_pub_.publish(pose_array(particles)); }

void Ros1Node::publish_hypotheses(const node::PosesOut& hypotheses) { hypotheses_pub_.publish(pose_array(hypotheses)); }

void Ros1Node::publish_diagnostics(const node::DiagnosticOut& status) {
  diagnostic_msgs::DiagnosticStatus s;
  s.level = status.level;
  s.name = status.name;
  s.message = status.message;
  s.hardware_id = status.hardware_id;
  for (const auto& [key, value] : status.values) {
    diagnostic_msgs::KeyValue kv;
    kv.key = key;
    kv.value = value;
    s.values.push_back(kv);
  }
  diagnostic_msgs::DiagnosticArray array;
  array.header.stamp = ros_time(status.stamp);
  array.status.push_back(s);
  diagnostics_pub_.publish(array);
}

void Ros1Node::send_transform(const node::TransformOut& transform) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = ros_time(transform.stamp);
  t.header.frame_id = transform.parent;
  t.child_frame_id = transform.child;
  t.transform = transform_from_pose(transform.pose);
  tf_broadcaster_.sendTransform(t);
}

void Ros1Node::publish_map_cloud(const node::CloudOut& cloud) { map_cloud_pub_.publish(msg_from_cloud(cloud)); }

std::optional<node::Stamp> Ros1Node::now() {
  if (!ros::Time::isSimTime()) return std::nullopt;
  const ros::Time t = ros::Time::now();
  if (t.isZero()) return std::nullopt;
  return node::Stamp{static_cast<std::int64_t>(t.sec) * 1000000000 + t.nsec};
}

void Ros1Node::log(node::LogLevel level, const std::string& text) {
  switch (level) {
    case node::LogLevel::kInfo:
      ROS_INFO("%s", text.c_str());
      break;
    case node::LogLevel::kWarn:
      ROS_WARN("%s", text.c_str());
      break;
    case node::LogLevel::kError:
      ROS_ERROR("%s", text.c_str());
      break;
  }
}

std::string Ros1Node::parameter_name(const std::string& name) { return parameters_.shown(name); }

std::string Ros1Node::static_transform_command(const std::string& parent, const std::string& child) {
  return "rosrun tf2_ros static_transform_publisher X Y Z YAW PITCH ROLL " + parent + " " + child;
}

}  // namespace tsdf_mcl::ros_node
