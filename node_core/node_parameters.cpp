// The node's parameters: its own (NodeSettings) and the filter's, by the library schema's names, each validated; and
// a warning for every parameter that neither knows.
#include "node_parameters.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"

namespace tsdf_mcl::node {
namespace {

const std::string kExtrinsics = "sensor_extrinsics.";

const ParameterValue* find(const NodeParameters& p, const std::string& name) {
  const auto it = p.values.find(name);
  return it == p.values.end() ? nullptr : &it->second;
}

// A text parameter: any scalar's text (a frame named 1 is "1"); a list or a struct is an error.
std::string text_param(const NodeParameters& p, const std::string& name, const std::string& value) {
  const ParameterValue* v = find(p, name);
  if (!v) return value;
  if (v->type == ParameterValue::Type::kList || v->type == ParameterValue::Type::kOther) {
    throw Error(p.shown(name) + " must be text, got '" + one_line(v->text) + "'");
  }
  return v->text;
}

// A number parameter within [min, max]; `integral` ones must be whole. Absent: `value`. Anything else (text, NaN,
// out of range) is an Error naming the parameter and the range, never a silent default.
double number_param(const NodeParameters& p, const std::string& name, double value, double min, double max,
                    bool integral) {
  const ParameterValue* v = find(p, name);
  if (!v) return value;
  char range[96];
  std::snprintf(range, sizeof(range), "%s in %g..%g", integral ? "a whole number" : "a number", min, max);
  if (v->type != ParameterValue::Type::kInteger && v->type != ParameterValue::Type::kDouble) {
    throw Error(p.shown(name) + " must be " + range + ", got '" + one_line(v->text) + "'");
  }
  const double x = std::strtod(v->text.c_str(), nullptr);
  if (!(x >= min && x <= max) || (integral && x != std::floor(x))) {
    char got[64];
    std::snprintf(got, sizeof(got), "%.17g", x);
    throw Error(p.shown(name) + " must be " + range + ", got " + got);
  }
  return x;
}

bool flag_param(const NodeParameters& p, const std::string& name, bool value) {
  const ParameterValue* v = find(p, name);
  if (!v) return value;
  std::string t = v->text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (t == "true" || t == "1" || t == "yes" || t == "on") return true;
  if (t == "false" || t == "0" || t == "no" || t == "off") return false;
  throw Error(p.shown(name) + " must be true or false, got '" + one_line(v->text) + "'");
}

std::vector<std::string> split_items(const std::string& text) {
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
  return items;
}

// sensor_extrinsics.<frame>: [x, y, z, roll, pitch, yaw] (m; radians or with a unit, "90deg"), base_frame_id ->
// frame. A value may also be text ("0 0 0.5 0 0 90deg"): ROS 1's `_sensor_extrinsics/lidar:=...` gives text.
std::map<std::string, Pose> sensor_extrinsics_of(const NodeParameters& p) {
  std::map<std::string, Pose> extrinsics;
  for (const auto& [name, value] : p.values) {
    if (name.rfind(kExtrinsics, 0) != 0) continue;
    const std::string frame = name.substr(kExtrinsics.size());
    const std::string what = p.shown(name);
    if (value.type == ParameterValue::Type::kOther) throw Error(what + ": " + value.text);
    const std::vector<std::string> items = split_items(value.text);
    if (items.size() != 6) {
      throw Error(what + " must be x, y, z, roll, pitch, yaw (m, and radians or e.g. 90deg), got '" +
                  one_line(value.text) + "'");
    }
    double v[6];
    const char* names[] = {"x", "y", "z", "roll", "pitch", "yaw"};
    for (int i = 0; i < 6; ++i) {
      const std::string item_name = what + "'s " + names[i];
      if (i >= 3) {
        v[i] = parse_angle(items[i], item_name, 2.0 * M_PI);
        continue;
      }
      // A mounting offset beyond 100 m is a typo (millimetres for metres), not a robot.
      char* end = nullptr;
      v[i] = std::strtod(items[i].c_str(), &end);
      if (end != items[i].c_str() + items[i].size() || !(std::abs(v[i]) <= 100.0)) {
        throw Error(item_name + " must be a number in -100..100 m, got '" + one_line(items[i]) + "'");
      }
    }
    extrinsics[frame] = pose_from_xyz_rpy(v[0], v[1], v[2], v[3], v[4], v[5]);
  }
  return extrinsics;
}

void check_frames(const NodeParameters& p, const NodeSettings& s) {
  const auto empty = [&](const std::string& name, const std::string& frame) {
    if (frame.empty()) throw Error(p.shown(name) + " is empty: name a tf frame");
  };
  empty("global_frame_id", s.global_frame_id);
  empty("base_frame_id", s.base_frame_id);
  empty("odom_frame_id", s.odom_frame_id);
  const auto same = [&](const std::string& a, const std::string& b, const std::string& frame, const char* why) {
    throw Error(p.shown(a) + " and " + p.shown(b) + " are both '" + one_line(frame) + "': " + why);
  };
  if (s.base_frame_id == s.global_frame_id) {
    same("base_frame_id", "global_frame_id", s.base_frame_id, "the node estimates the one in the other");
  }
  if (s.odom_frame_id == s.base_frame_id) {
    same("odom_frame_id", "base_frame_id", s.odom_frame_id, "odometry moves the base in the odometry frame");
  }
  if (s.odom_frame_id == s.global_frame_id) {
    same("odom_frame_id", "global_frame_id", s.odom_frame_id, "the node publishes the one in the other on tf");
  }
}

// Every name of the library's parameter schema (localizer_parameters.hpp) and its amcl aliases.
std::vector<std::string> schema_names() {
  std::vector<std::string> names;
  for (const ParameterSpec& spec : localizer_parameter_specs()) names.push_back(spec.name);
  for (const ParameterAlias& alias : localizer_parameter_aliases()) names.push_back(alias.alias);
  return names;
}

}  // namespace

std::string NodeParameters::shown(const std::string& name) const {
  std::string out = prefix + name;
  std::replace(out.begin() + static_cast<std::ptrdiff_t>(prefix.size()), out.end(), '.', separator);
  return out;
}

std::string default_last_pose_file(const std::string& node_name) {
  std::string home;
  if (const char* ros_home = std::getenv("ROS_HOME")) {
    home = ros_home;
  } else if (const char* user_home = std::getenv("HOME")) {
    home = std::string(user_home) + "/.ros";
  } else {
    return "";
  }
  std::string name = node_name.substr(node_name.rfind('/', 0) == 0 ? 1 : 0);
  std::replace(name.begin(), name.end(), '/', '_');
  return home + "/" + name + "_last_pose.json";
}

const std::vector<std::string>& node_parameter_names() {
  static const std::vector<std::string> names = {"map_file",         "global_frame_id",     "odom_frame_id",
                                                 "base_frame_id",    "point_topics",        "odom_topic",
                                                 "imu_topic",        "transform_tolerance", "tf_timeout",
                                                 "merge_window",     "tf_broadcast",        "max_published_particles",
                                                 "map_cloud_points", "last_pose_file"};
  return names;
}

NodeSettings settings_from(const NodeParameters& p, const std::string& fallback_last_pose_file) {
  NodeSettings s;
  s.map_file = text_param(p, "map_file", "");
  if (s.map_file.empty()) throw Error(p.shown("map_file") + " is not set (a TSDF map from tsdf-mcl build-map)");
  s.global_frame_id = text_param(p, "global_frame_id", s.global_frame_id);
  s.odom_frame_id = text_param(p, "odom_frame_id", s.odom_frame_id);
  s.base_frame_id = text_param(p, "base_frame_id", s.base_frame_id);
  check_frames(p, s);
  if (const ParameterValue* topics = find(p, "point_topics")) {
    s.point_topics.clear();
    std::stringstream in(topics->text);
    for (std::string t; std::getline(in, t, ',');)
      if (!t.empty()) s.point_topics.push_back(t);
    if (s.point_topics.empty()) throw Error(p.shown("point_topics") + " names no topic");
  }
  s.odom_topic = text_param(p, "odom_topic", s.odom_topic);
  s.imu_topic = text_param(p, "imu_topic", s.imu_topic);
  s.transform_tolerance = number_param(p, "transform_tolerance", s.transform_tolerance, 0.0, 60.0, false);
  s.tf_timeout = number_param(p, "tf_timeout", s.tf_timeout, 0.0, 10.0, false);
  s.merge_window = number_param(p, "merge_window", s.merge_window, 0.0, 10.0, false);
  s.tf_broadcast = flag_param(p, "tf_broadcast", s.tf_broadcast);
  s.max_published_particles =
      static_cast<int>(number_param(p, "max_published_particles", s.max_published_particles, 0, 1e7, true));
  s.map_cloud_points = static_cast<int>(number_param(p, "map_cloud_points", s.map_cloud_points, 0, 1e8, true));
  s.sensor_extrinsics = sensor_extrinsics_of(p);
  s.last_pose_file = text_param(p, "last_pose_file", fallback_last_pose_file);
  return s;
}

LocalizerOptions localizer_options_of(const NodeParameters& p) {
  std::map<std::string, std::string> values;
  for (const std::string& name : schema_names()) {
    const ParameterValue* v = find(p, name);
    if (!v) continue;
    if (v->type == ParameterValue::Type::kOther) throw Error(p.shown(name) + ": " + v->text);
    values[name] = v->text;
  }
  try {
    return localizer_options_from(values);
  } catch (const Error& e) {
    throw Error("parameter " + p.prefix + e.what());
  }
}

std::vector<std::string> unknown_parameter_warnings(const NodeParameters& p,
                                                    const std::vector<std::string>& transport_names) {
  std::vector<std::string> known = node_parameter_names();
  known.insert(known.end(), transport_names.begin(), transport_names.end());
  for (const std::string& name : schema_names()) known.push_back(name);
  std::vector<std::string> shown_known;
  for (const std::string& name : known) shown_known.push_back(p.shown(name).substr(p.prefix.size()));
  std::vector<std::string> warnings;
  for (const auto& [name, value] : p.values) {
    if (name.rfind(kExtrinsics, 0) == 0) continue;  // one per frame, any frame name
    if (std::find(known.begin(), known.end(), name) != known.end()) continue;
    const std::string shown_name = p.shown(name);
    warnings.push_back("unknown parameter " + shown_name + " ignored" +
                       did_you_mean(shown_name.substr(p.prefix.size()), shown_known, p.prefix));
  }
  return warnings;
}

}  // namespace tsdf_mcl::node
