#include "tsdf_mcl/localizer/localizer_parameters.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <set>
#include <sstream>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "parameter_table.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kFullTurn = 2.0 * M_PI;

// A value that is not of its parameter's kind (a word for a number, a number for a flag, a name not among the
// choices): check_parameter_types tells it from a value of the right kind out of range.
struct ValueTypeError : Error {
  using Error::Error;
};

std::string num(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// The given values with the schema's defaults behind them; every accessor's Error names the parameter.
class Values {
 public:
  explicit Values(const std::map<std::string, std::string>& given);

  bool given(const std::string& name) const { return given_.count(name) != 0; }
  std::string text(const std::string& name) const;
  double number(const std::string& name) const;
  double positive(const std::string& name) const;
  double angle(const std::string& name) const { return parse_angle(text(name), name, kFullTurn); }
  std::size_t count(const std::string& name, std::size_t max = std::numeric_limits<std::size_t>::max()) const;
  bool flag(const std::string& name) const;
  std::vector<std::string> list(const std::string& name) const;
  // The text through a parser of names (parse_backend, ...), whose Error is a ValueTypeError.
  template <typename Parse>
  auto parsed(const std::string& name, Parse parse) const {
    const std::string v = text(name);
    try {
      return parse(v);
    } catch (const ValueTypeError&) {
      throw;
    } catch (const Error& e) {
      throw ValueTypeError(e.what());
    }
  }

 private:
  std::map<std::string, std::string> given_;
  std::map<std::string, std::string> defaults_;
};

std::string canonical_value(const std::string& alias, const std::string& value) {
  if (alias != "odom_model_type") return value;
  static const std::set<std::string> kinds = {"diff", "omni", "diff-corrected", "omni-corrected"};
  if (!kinds.count(value)) {
    throw Error(
        "odom_model_type must be diff, omni, diff-corrected or omni-corrected (all mean motion_model "
        "odometry), got '" +
        value + "'");
  }
  return "odometry";
}

Values::Values(const std::map<std::string, std::string>& given) : given_(canonical_parameters(given)) {
  for (const ParameterSpec& s : localizer_parameter_specs()) defaults_[s.name] = s.default_value;
}

std::string Values::text(const std::string& name) const {
  if (const auto it = given_.find(name); it != given_.end()) return it->second;
  const auto d = defaults_.find(name);
  if (d == defaults_.end()) throw Error("internal: no parameter " + name);
  if (d->second.empty()) throw Error("missing parameter " + name);
  return d->second;
}

double Values::number(const std::string& name) const {
  const std::string v = text(name);
  errno = 0;
  char* end = nullptr;
  const double d = std::strtod(v.c_str(), &end);
  if (v.empty() || end != v.c_str() + v.size() || errno != 0 || !std::isfinite(d)) {
    throw ValueTypeError(name + " expects a number, got '" + v + "'");
  }
  return d;
}

double Values::positive(const std::string& name) const {
  const double v = number(name);
  if (!(v > 0.0)) throw Error(name + " must be positive");
  return v;
}

std::size_t Values::count(const std::string& name, std::size_t max) const {
  const std::string v = text(name);
  errno = 0;
  char* end = nullptr;
  const long long n = std::strtoll(v.c_str(), &end, 10);
  if (v.empty() || end != v.c_str() + v.size() || errno != 0) {
    throw ValueTypeError(name + " expects an integer, got '" + v + "'");
  }
  if (n < 0) throw Error(name + " must not be negative");
  if (static_cast<unsigned long long>(n) > max) {
    throw Error(name + " " + v + " is more than the limit of " + std::to_string(max));
  }
  return static_cast<std::size_t>(n);
}

bool Values::flag(const std::string& name) const {
  const auto it = given_.find(name);
  if (it == given_.end()) return false;
  const std::string& v = it->second;
  if (v == "1" || v == "true" || v == "True" || v == "yes" || v == "on") return true;
  if (v == "0" || v == "false" || v == "False" || v == "no" || v == "off" || v.empty()) return false;
  throw ValueTypeError(name + " expects true or false, got '" + v + "'");
}

std::vector<std::string> Values::list(const std::string& name) const {
  std::vector<std::string> out;
  std::stringstream ss(text(name));
  for (std::string item; std::getline(ss, item, ',');) {
    if (item.empty()) throw ValueTypeError(name + " has an empty item");
    out.push_back(item);
  }
  return out;
}

void set_filter(FilterParameters& f, const Values& v) {
  f.initial_particles = v.count("particles", limits::kMaxParticles);
  f.kld.min_particles = v.count("min_particles", limits::kMaxParticles);
  f.kld.max_particles = v.count("max_particles", limits::kMaxParticles);
  f.kld.pf_err = v.number("pf_err");
  f.kld.pf_z = v.number("pf_z");
  f.resample_interval = v.count("resample_interval");
  f.recovery.alpha_slow = v.number("recovery_alpha_slow");
  f.recovery.alpha_fast = v.number("recovery_alpha_fast");
  f.seed = v.count("seed");
}

void set_sensor(FilterParameters& f, const Values& v) {
  f.sensor.sigma_hit = static_cast<float>(v.number("sigma_hit"));
  f.sensor.z_hit = static_cast<float>(v.number("z_hit"));
  f.sensor.z_rand = static_cast<float>(v.number("z_rand"));
  f.sensor.max_range = static_cast<float>(v.positive("laser_max_range"));
}

void set_motion(FilterParameters& f, const Values& v) {
  f.motion.type = v.parsed("motion_model", parse_motion_model);
  double* alphas[] = {&f.motion.alpha1, &f.motion.alpha2, &f.motion.alpha3, &f.motion.alpha4,
                      &f.motion.alpha5, &f.motion.alpha6, &f.motion.alpha7, &f.motion.alpha8};
  for (int i = 0; i < 8; ++i) *alphas[i] = v.number("alpha" + std::to_string(i + 1));
  const double imu_sigma = v.angle("imu_rotation_sigma");
  if (imu_sigma < 0.0) throw Error("imu_rotation_sigma must not be negative");
  f.motion.imu_rotation = imu_sigma > 0.0;
  if (f.motion.imu_rotation) f.motion.imu_sigma = imu_sigma;
  // The random walk's vertical and roll/pitch terms follow the horizontal ones in the defaults' proportions.
  f.motion.diffusion_xy = v.number("diffusion_xy");
  f.motion.diffusion_z = 0.25 * f.motion.diffusion_xy;
  f.motion.diffusion_yaw = v.angle("diffusion_yaw");
  f.motion.diffusion_roll_pitch = 0.3 * f.motion.diffusion_yaw;
  f.update_min_d = v.number("update_min_d");
  f.update_min_a = v.angle("update_min_a");
}

void set_initialization(FilterParameters& f, const Values& v) {
  f.global_init.max_tilt = v.angle("init_max_tilt");
  if (v.given("init_height_band")) {
    const std::vector<std::string> band = v.list("init_height_band");
    if (band.size() != 2) throw ValueTypeError("init_height_band expects MIN,MAX");
    f.global_init.use_height_band = true;
    f.global_init.min_height = Values({{"init_height_band", band[0]}}).number("init_height_band");
    f.global_init.max_height = Values({{"init_height_band", band[1]}}).number("init_height_band");
  }
  f.global_search.candidates = v.count("init_candidates", limits::kMaxParticles);
  f.local_init.sigma_xy = v.number("init_sigma_xy");
  f.local_init.sigma_z = v.number("init_sigma_z");
  f.local_init.sigma_yaw = v.angle("init_sigma_yaw");
  f.local_init.sigma_roll_pitch = 0.2 * f.local_init.sigma_yaw;
}

void set_decision(FilterParameters& f, const Values& v) {
  f.ledger.decide_nats = v.number("evidence_nats");
  f.ledger.window_m = v.number("proof_travel");
  f.states.min_inliers = v.number("converged_min_inliers");
  f.recovery.min_inliers = v.number("recovery_min_inliers");
}

// The initial pose of init x,y,z,roll,pitch,yaw or init initial_pose; nullopt for global.
std::optional<Pose> initial_pose(const Values& v) {
  const std::string init = v.text("init");
  double p[6];
  // initial_pose.* are checked whether or not init names them, so a bad value is never silently kept.
  const char* keys[] = {"x", "y", "z", "roll", "pitch", "yaw"};
  for (int i = 0; i < 6; ++i) {
    const std::string name = std::string("initial_pose.") + keys[i];
    p[i] = i < 3 ? v.number(name) : v.angle(name);
  }
  if (init == "global") return std::nullopt;
  if (init != "initial_pose") {
    const std::vector<std::string> items = v.list("init");
    if (items.size() != 6) {
      throw ValueTypeError("init expects global, initial_pose or x,y,z,roll,pitch,yaw (6 numbers)");
    }
    const char* names[] = {"x", "y", "z", "roll", "pitch", "yaw"};
    for (int i = 0; i < 6; ++i) {
      const std::string what = std::string("init's ") + names[i];
      p[i] = i < 3 ? Values({{"init", items[i]}}).number("init") : parse_angle(items[i], what, kFullTurn);
    }
  }
  return pose_from_xyz_rpy(p[0], p[1], p[2], p[3], p[4], p[5]);
}

// Edit distance, for "did you mean".
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

}  // namespace

const std::vector<ParameterSpec>& localizer_parameter_specs() {
  static const std::vector<ParameterSpec> specs = localizer_parameter_table();
  return specs;
}

std::string parameters_markdown() {
  std::ostringstream md;
  md << "# Parameters\n\n"
        "<!-- Generated from the parameter table (src/localizer/parameter_table.cpp) by `tsdf-mcl localize "
        "--help-markdown`; a test fails when this file differs. -->\n\n"
        "Every parameter `tsdf-mcl localize` takes (as `--name value` or from `--config FILE`), the ROS nodes read "
        "and the Python module accepts, by the same name. Angles are in radians as in nav2, or with a unit "
        "(`90deg`). `localize --help` lists all but the expert ones; `--help-all` lists them all. Everything else "
        "the filter has is a design constant of its options structs, described in [filter.md](filter.md).\n";
  std::vector<std::string> groups;
  for (const ParameterSpec& s : localizer_parameter_specs()) {
    if (std::find(groups.begin(), groups.end(), s.group) == groups.end()) groups.push_back(s.group);
  }
  for (const std::string& group : groups) {
    md << "\n## " << group << "\n\n| name | value | default | what it does |\n|---|---|---|---|\n";
    for (const ParameterSpec& s : localizer_parameter_specs()) {
      if (s.group != group) continue;
      md << "| `" << s.name << "` | " << (s.value_name.empty() ? "flag" : s.value_name) << " | "
         << (s.default_value.empty() ? "" : "`" + s.default_value + "`") << " | " << s.help << " |\n";
    }
  }
  md << "\n## amcl's names\n\nROS 1 amcl's names are accepted for ours where the meaning carries over:\n\n"
        "| amcl | tsdf-mcl |\n|---|---|\n";
  for (const ParameterAlias& a : localizer_parameter_aliases()) md << "| `" << a.alias << "` | `" << a.name << "` |\n";
  return md.str();
}

const std::vector<ParameterAlias>& localizer_parameter_aliases() {
  static const std::vector<ParameterAlias> aliases = {
      {"laser_max_beams", "max_beams"},
      {"odom_alpha1", "alpha1"},
      {"odom_alpha2", "alpha2"},
      {"odom_alpha3", "alpha3"},
      {"odom_alpha4", "alpha4"},
      {"odom_alpha5", "alpha5"},
      {"kld_err", "pf_err"},
      {"kld_z", "pf_z"},
      {"laser_z_hit", "z_hit"},
      {"laser_z_rand", "z_rand"},
      {"laser_sigma_hit", "sigma_hit"},
      {"odom_model_type", "motion_model"},
      {"initial_pose_x", "initial_pose.x"},
      {"initial_pose_y", "initial_pose.y"},
      {"initial_pose_a", "initial_pose.yaw"},
  };
  return aliases;
}

std::map<std::string, std::string> canonical_parameters(const std::map<std::string, std::string>& values) {
  std::vector<std::string> known;
  for (const ParameterSpec& s : localizer_parameter_specs()) known.push_back(s.name);
  std::map<std::string, std::string> alias_of;
  for (const ParameterAlias& a : localizer_parameter_aliases()) alias_of[a.alias] = a.name;
  std::map<std::string, std::string> out;
  for (const auto& [name, value] : values) {
    if (value.find('\0') != std::string::npos) throw Error(name + ": the value holds a NUL character");
    if (std::find(known.begin(), known.end(), name) != known.end()) {
      out[name] = value;
      continue;
    }
    const auto alias = alias_of.find(name);
    if (alias == alias_of.end()) throw Error("unknown parameter '" + name + "'" + did_you_mean(name, known));
    if (values.count(alias->second)) {
      throw Error(name + " is amcl's name of " + alias->second + ": give one of them, not both");
    }
    out[alias->second] = canonical_value(name, value);
  }
  return out;
}

void check_parameter_types(const std::map<std::string, std::string>& values) {
  for (const auto& [name, value] : canonical_parameters(values)) {
    try {
      (void)localizer_options_from({{name, value}});
    } catch (const ValueTypeError&) {
      throw;
    } catch (const Error&) {
      // Of the right kind; whether it fits the other values is checked where they are merged.
    }
  }
}

LocalizerOptions localizer_options_from(const std::map<std::string, std::string>& values) {
  const Values v(values);
  LocalizerOptions lo;
  set_filter(lo.filter, v);
  set_sensor(lo.filter, v);
  set_motion(lo.filter, v);
  set_initialization(lo.filter, v);
  set_decision(lo.filter, v);
  lo.filter.validate();
  lo.preprocessing.laser_min_range = static_cast<float>(v.number("laser_min_range"));
  lo.preprocessing.laser_max_range = static_cast<float>(v.number("laser_max_range"));
  lo.preprocessing.voxel_size = static_cast<float>(v.number("scan_voxel"));
  lo.preprocessing.max_beams = v.count("max_beams", limits::kMaxBeams);
  lo.preprocessing.seed = v.count("seed");
  lo.preprocessing.validate();
  lo.initial_pose = initial_pose(v);
  lo.use_imu = !v.flag("ignore_imu");
  lo.evaluator.backend = v.parsed("backend", parse_backend);
  lo.evaluator.cpu_threads = static_cast<int>(v.count("cpu_threads", limits::kMaxThreads));
  return lo;
}

std::vector<std::string> closest_names(const std::string& name, const std::vector<std::string>& known) {
  // Close: a few edits for the name's length, or one name containing the other (pf_zz, max_beam, beams).
  const std::size_t budget = std::max<std::size_t>(2, name.size() / 4);
  std::vector<std::pair<std::size_t, std::string>> scored;
  for (const std::string& k : known) {
    std::size_t d = edit_distance(name, k);
    const bool contains = name.size() >= 4 && (k.find(name) != std::string::npos || name.find(k) != std::string::npos);
    if (contains) d = std::min(d, budget);
    if (d <= budget) scored.emplace_back(d, k);
  }
  std::stable_sort(scored.begin(), scored.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::string> out;
  for (const auto& s : scored) {
    if (out.size() == 3) break;
    out.push_back(s.second);
  }
  return out;
}

std::string did_you_mean(const std::string& name, const std::vector<std::string>& known, const std::string& prefix) {
  const std::vector<std::string> close = closest_names(name, known);
  if (close.empty()) return "";
  std::string text = " (did you mean ";
  for (std::size_t i = 0; i < close.size(); ++i) text += (i == 0 ? "" : ", ") + prefix + close[i];
  return text + "?)";
}

double parse_angle(const std::string& text, const std::string& what, double max_abs) {
  std::string number = text;
  double scale = 1.0;
  bool explicit_unit = false;
  for (const auto& [suffix, factor] : {std::pair<const char*, double>{"deg", M_PI / 180.0}, {"rad", 1.0}}) {
    const std::string s = suffix;
    if (number.size() > s.size() && number.compare(number.size() - s.size(), s.size(), s) == 0) {
      number.resize(number.size() - s.size());
      scale = factor;
      explicit_unit = true;
      break;
    }
  }
  errno = 0;
  char* end = nullptr;
  const double d = std::strtod(number.c_str(), &end);
  if (number.empty() || end != number.c_str() + number.size() || errno != 0 || !std::isfinite(d)) {
    throw ValueTypeError(what + " expects an angle (radians, or e.g. 90deg), got '" + text + "'");
  }
  const double radians = d * scale;
  if (std::abs(radians) > max_abs + 1e-9) {
    if (!explicit_unit) {
      throw Error(what + " " + text + " is more than " + num(max_abs) +
                  " rad: angles are in radians; for degrees write " + text + "deg");
    }
    throw Error(what + " " + text + " is more than " + num(max_abs) + " rad (" + num(max_abs * 180.0 / M_PI) + " deg)");
  }
  return radians;
}

}  // namespace tsdf_mcl
