// The node's parameters: its own (NodeSettings) and the filter's, by the library schema's names, each validated;
// and a warning for every parameter of the private namespace that neither knows.
#include "node_parameters.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"
#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"

namespace tsdf_mcl::ros_node {
namespace {

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

}  // namespace

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

namespace {

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

}  // namespace

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

}  // namespace tsdf_mcl::ros_node
