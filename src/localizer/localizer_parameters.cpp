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

namespace tsdf_mcl {
namespace {

constexpr double kFullTurn = 2.0 * M_PI;

std::string num(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// localize --help's sections (ParameterSpec::group).
const char* const kInit = "initialization";
const char* const kFilter = "filter";
const char* const kSensor = "sensor model";
const char* const kAdvanced = "advanced";

// How the filter starts: global search or a given pose, and what narrows the global search.
std::vector<ParameterSpec> initialization_specs(const FilterParameters& f) {
  return {
      {"init", "MODE", "global",
       "global (search the whole map), x,y,z,roll,pitch,yaw (m, rad; or e.g. 90deg), or initial_pose (the "
       "initial_pose.* values)",
       kInit},
      {"particles", "N", std::to_string(f.initial_particles), "particles of the initialization (global or local)",
       kInit},
      {"initial_pose.x", "M", "0", "initial pose for --init initial_pose: x", kInit},
      {"initial_pose.y", "M", "0", "... y", kInit},
      {"initial_pose.z", "M", "0", "... z", kInit},
      {"initial_pose.roll", "RAD", "0", "... roll", kInit},
      {"initial_pose.pitch", "RAD", "0", "... pitch", kInit},
      {"initial_pose.yaw", "RAD", "0", "... yaw", kInit},
      {"init_height_band", "MIN,MAX", "",
       "global init: sensor height above the floor below it (ground robot), e.g. 0.3,1.5", kInit},
      {"init_max_tilt", "RAD", num(f.global_init.max_tilt),
       "global init: sensor z axis within this angle of the world's (gravity known); pi = any rotation", kInit},
      {"ignore_imu", "", "",
       "do not use the dataset's IMU, imu.txt or a bag's --imu_topic (gravity for the global search, "
       "docs/filter.md)",
       kInit},
  };
}

// The global search's tuning (also recovery's draws from the proposal).
std::vector<ParameterSpec> global_search_specs(const FilterParameters& f) {
  return {
      {"init_min_clearance", "M", num(f.global_init.min_clearance), "global init: minimum distance from surfaces",
       kAdvanced},
      {"init_candidates", "N", std::to_string(f.global_search.candidates),
       "global init: hypotheses drawn from the first scan's up-direction and height candidates and scored; the best "
       "--particles are kept",
       kAdvanced},
      {"init_screen_points", "N", std::to_string(f.global_search.screen_points),
       "global init: scan points each hypothesis is scored on", kAdvanced},
      {"init_screen_sigma", "M", num(f.global_search.screen_sigma),
       "global init: endpoint-model sigma of that scoring (wide: hypotheses a little off still score)", kAdvanced},
      {"init_uniform_share", "R", num(f.global_search.proposal.uniform_share),
       "global init and recovery: share of hypotheses uniform over free space and rotations (the rest follow the "
       "scan's up and floor height)",
       kAdvanced},
  };
}

// The spread around a given initial pose.
std::vector<ParameterSpec> local_init_specs(const FilterParameters& f) {
  return {
      {"init_sigma_xy", "M", num(f.local_init.sigma_xy), "local init: position spread in x and y", kInit},
      {"init_sigma_z", "M", num(f.local_init.sigma_z), "local init: spread in z", kInit},
      {"init_sigma_yaw", "RAD", num(f.local_init.sigma_yaw), "local init: yaw spread", kInit},
      {"init_sigma_roll_pitch", "RAD", num(f.local_init.sigma_roll_pitch), "local init: roll and pitch spread", kInit},
  };
}

// Particle counts, the motion model, when to update and what the estimate is.
std::vector<ParameterSpec> filter_basics_specs(const FilterParameters& f) {
  return {
      {"min_particles", "N", std::to_string(f.kld.min_particles), "KLD-sampling: fewest particles", kFilter},
      {"max_particles", "N", std::to_string(f.kld.max_particles), "KLD-sampling: most particles", kFilter},
      {"motion_model", "NAME", to_string(f.motion.type), "odometry (odom.txt), constant_velocity or diffusion",
       kFilter},
      {"update_min_d", "M", num(f.update_min_d), "filter update only after this much translation (odometry model)",
       kFilter},
      {"update_min_a", "RAD", num(f.update_min_a), "... or this much rotation", kFilter},
      {"pose_estimate", "MODE", "mean", "mean (weighted mean of the dominant mode) or best (highest-weight particle)",
       kFilter},
  };
}

// The motion models' noise: odometry's alphas, the IMU's rotation, the random walk.
std::vector<ParameterSpec> motion_noise_specs(const FilterParameters& f) {
  return {
      {"alpha1", "A", num(f.motion.alpha1), "yaw noise from rotation (rad/rad)", kFilter},
      {"alpha2", "A", num(f.motion.alpha2), "yaw noise from translation (rad/m)", kFilter},
      {"alpha3", "A", num(f.motion.alpha3), "along-track translation noise from translation (m/m)", kFilter},
      {"alpha4", "A", num(f.motion.alpha4), "translation noise from rotation (m/rad)", kFilter},
      {"alpha5", "A", num(f.motion.alpha5), "cross-track translation noise from translation (m/m)", kFilter},
      {"alpha6", "A", num(f.motion.alpha6), "vertical (sensor z) translation noise from translation (m/m)", kFilter},
      {"alpha7", "A", num(f.motion.alpha7), "roll/pitch noise from rotation (rad/rad)", kFilter},
      {"alpha8", "A", num(f.motion.alpha8), "roll/pitch noise from translation (rad/m)", kFilter},
      {"imu_rotation", "", "",
       "trust the odometry's relative rotation (IMU): rotation noise imu_sigma instead of alpha1/2/7/8", kFilter},
      {"imu_sigma", "RAD", num(f.motion.imu_sigma), "rotation noise per update with --imu_rotation", kFilter},
      {"diffusion_xy", "M", num(f.motion.diffusion_xy), "random walk of constant_velocity/diffusion, per sqrt(s)",
       kFilter},
      {"diffusion_z", "M", num(f.motion.diffusion_z), "... in z", kFilter},
      {"diffusion_yaw", "RAD", num(f.motion.diffusion_yaw), "... in yaw", kFilter},
      {"diffusion_roll_pitch", "RAD", num(f.motion.diffusion_roll_pitch), "... in roll and pitch", kFilter},
  };
}

// Resampling and recovery's fit averages.
std::vector<ParameterSpec> resampling_specs(const FilterParameters& f) {
  return {
      {"resample_method", "NAME", to_string(f.resample_method), "systematic (low variance), residual or multinomial",
       kFilter},
      {"resample_interval", "N", std::to_string(f.resample_interval), "consider resampling every N-th filter update",
       kFilter},
      {"recovery_alpha_slow", "A", num(f.recovery_alpha_slow), "recovery: long-term fit average rate (0 = no recovery)",
       kFilter},
      {"recovery_alpha_fast", "A", num(f.recovery_alpha_fast),
       "recovery: short-term fit average rate (0 = no recovery)", kFilter},
  };
}

// Sensor model and scan preprocessing.
std::vector<ParameterSpec> sensor_model_specs(const FilterParameters& f, const ScanPreprocessing& s) {
  return {
      {"laser_min_range", "M", num(s.laser_min_range), "drop scan points closer than this", kSensor},
      {"laser_max_range", "M", num(s.laser_max_range), "drop scan points farther than this", kSensor},
      {"max_beams", "N", std::to_string(s.max_beams),
       "points per scan used in the sensor update, spread over the whole scan", kSensor},
      {"scan_voxel", "M", num(s.voxel_size), "thin the scan to one point per voxel of this size (0 = off)", kSensor},
      {"sigma_hit", "M", num(f.sensor.sigma_hit), "endpoint model: standard deviation of the distance to the surface",
       kSensor},
      {"z_hit", "W", num(f.sensor.z_hit), "endpoint model: weight of the hit Gaussian", kSensor},
      {"z_rand", "W", num(f.sensor.z_rand), "endpoint model: weight of the uniform part (z_rand / laser_max_range)",
       kSensor},
      {"likelihood", "FORM", "product",
       "product (joint likelihood, log domain) or sum (the reference implementation's form)", kSensor},
      {"interpolation", "MODE", "nearest", "TSDF lookup: nearest or trilinear", kSensor},
      {"weight_exponent", "X", num(f.sensor.weight_exponent),
       "log-weight multiplier: tempers the joint likelihood of correlated points", kSensor},
      {"unknown_space", "AS", f.unknown_as_free ? "free" : "miss",
       "a scan point in the map's unknown space counts as one in free space beyond the truncation band (free) or as "
       "a miss, p_rand (miss, the reference implementation)",
       kSensor},
  };
}

// Where and how the sensor update runs, and the random seed.
std::vector<ParameterSpec> backend_specs() {
  return {
      {"backend", "NAME", "auto", "sensor update on auto (Vulkan if a device works, else CPU), vulkan or cpu",
       kAdvanced},
      {"cpu_threads", "N", "0", "threads of the CPU backend (0 = all)", kAdvanced},
      {"seed", "N", "0", "random seed; results are reproducible for a seed and backend", kAdvanced},
      {"weight_layout", "NAME", "auto",
       "vulkan: auto (a subgroup per particle on GPUs, an invocation per particle on CPU devices such as "
       "lavapipe), invocation or subgroup",
       kAdvanced},
  };
}

// KLD-sampling's bound and bins; when to resample, bring random particles or temper.
std::vector<ParameterSpec> kld_and_resampling_tuning_specs(const FilterParameters& f) {
  return {
      {"pf_err", "E", num(f.kld.pf_err), "KLD-sampling: bound on the KL divergence (epsilon)", kAdvanced},
      {"pf_z", "Z", num(f.kld.pf_z),
       "KLD-sampling: upper standard-normal quantile z_(1-delta), a number of standard deviations as in nav2, not "
       "a probability (0.99 -> 84 %, 2.33 -> 99 %)",
       kAdvanced},
      {"kld_bin_xy", "M", num(f.kld.bin_xy), "KLD-sampling: histogram bin in x and y", kAdvanced},
      {"kld_bin_z", "M", num(f.kld.bin_z), "KLD-sampling: histogram bin in z", kAdvanced},
      {"kld_bin_angle", "RAD", num(f.kld.bin_angle), "KLD-sampling: histogram bin in roll, pitch and yaw", kAdvanced},
      {"resample_ess_ratio", "R", num(f.resample_ess_ratio),
       "resample when the effective sample size drops below R * particles (1 = always)", kAdvanced},
      {"recovery_margin", "M", num(f.recovery_margin),
       "recovery: the short-term fit must fall this fraction below the long-term one before random particles "
       "come",
       kAdvanced},
      {"min_ess_ratio", "R", num(f.min_ess_ratio),
       "adaptive tempering: keep at least R * particles effective particles per update (0 = off)", kAdvanced},
  };
}

// Subset-first weighing.
std::vector<ParameterSpec> subset_first_specs(const FilterParameters& f) {
  return {
      {"subset_points", "K", std::to_string(f.subset_first.points),
       "subset first: weigh every particle on K of the scan's points first and only the best subset_share on all "
       "of them, in sets of at least subset_min_particles (0 = off; not on a discrete GPU, where the whole scan is "
       "faster)",
       kAdvanced},
      {"subset_share", "S", num(f.subset_first.share), "subset first: share of the particles weighed on the whole scan",
       kAdvanced},
      {"subset_min_particles", "N", std::to_string(f.subset_first.min_particles),
       "subset first: only in sets of at least N particles", kAdvanced},
  };
}

// Roughening until the first convergence.
std::vector<ParameterSpec> roughening_specs(const FilterParameters& f) {
  return {
      {"roughening_xyz", "M", num(f.roughening_xyz),
       "until the first convergence: extra random walk per update and axis", kAdvanced},
      {"roughening_angle", "RAD", num(f.roughening_angle), "... and per rotation axis", kAdvanced},
      {"roughening_interval", "S", num(f.roughening_interval),
       "until the first convergence: an update at least this often, moving or not", kAdvanced},
  };
}

// Mode finding and the convergence test.
std::vector<ParameterSpec> convergence_specs(const FilterParameters& f) {
  return {
      {"cluster_bin_xyz", "M", num(f.estimate.cluster_bin_xyz), "mode finding: grid cell size in x, y, z", kAdvanced},
      {"cluster_bin_yaw", "RAD", num(f.estimate.cluster_bin_yaw), "mode finding: grid cell size in yaw", kAdvanced},
      {"converged_weight", "W", num(f.estimate.converged_weight),
       "converged: share of weight in the dominant mode at least this", kAdvanced},
      {"converged_std_xyz", "M", num(f.estimate.converged_std_xyz),
       "converged: position standard deviation at most this", kAdvanced},
      {"converged_std_angle", "RAD", num(f.estimate.converged_std_angle),
       "converged: rotation standard deviation at most this", kAdvanced},
      {"converged_min_inliers", "R", num(f.convergence.min_inlier_ratio),
       "converged: at least this share of the scan's points within inlier_distance of a surface at the estimate",
       kAdvanced},
      {"converged_competitor_weight", "W", num(f.convergence.competitor_min_weight),
       "converged: no other hypothesis holding this much of the belief may fit the scan nearly as well (within "
       "0.1 inlier ratio)",
       kAdvanced},
      {"converged_min_updates", "N", std::to_string(f.convergence.min_updates),
       "converged: all of the above for this many consecutive filter updates at one place", kAdvanced},
      {"converged_travel_after_jump", "M", num(f.convergence.travel_after_jump_m),
       "converged: after the estimate jumped away from a place it had converged at or concentrated on, or after "
       "a wrong lock was found out, the new place must hold over this much travel first",
       kAdvanced},
  };
}

// The absolute fit measure, wrong locks, and the evidence between hypotheses.
std::vector<ParameterSpec> fit_and_hypotheses_specs(const FilterParameters& f) {
  return {
      {"inlier_distance", "M", num(f.inlier_distance),
       "a scan point within this distance of a surface is an inlier (the absolute fit measure)", kAdvanced},
      {"recovery_min_inliers", "R", num(f.recovery_min_inliers),
       "recovery: a concentrated belief whose inlier ratio stays below this is a wrong lock and searches again "
       "(0 = off)",
       kAdvanced},
      {"hypothesis_evidence_points", "N", num(f.hypothesis_evidence_points),
       "between hypotheses (modes) a scan counts as this many independent points of evidence (0 = untempered)",
       kAdvanced},
      {"hypothesis_min_particles", "N", std::to_string(f.hypothesis_min_particles),
       "each hypothesis with at least hypothesis_min_weight keeps this many particles through resampling", kAdvanced},
      {"hypothesis_min_weight", "W", num(f.hypothesis_min_weight),
       "... hypotheses lighter than this take their chances with the rest", kAdvanced},
  };
}

// Filter parameters keep nav2 AMCL's names and spelling (underscores) where the meaning carries over, so values
// from a nav2 YAML file move over unchanged; the 6-DoF additions follow the same style. Angles in radians as in
// nav2 (RAD), or with a deg/rad suffix.
std::vector<ParameterSpec> make_specs() {
  const FilterParameters f;
  const ScanPreprocessing s;
  std::vector<ParameterSpec> specs;
  for (const std::vector<ParameterSpec>& group : {
           initialization_specs(f),
           global_search_specs(f),
           local_init_specs(f),
           // Filter: particle counts, motion, estimate.
           filter_basics_specs(f),
           motion_noise_specs(f),
           resampling_specs(f),
           sensor_model_specs(f, s),
           // Advanced: backend, tuning knobs a user rarely needs.
           backend_specs(),
           kld_and_resampling_tuning_specs(f),
           subset_first_specs(f),
           roughening_specs(f),
           convergence_specs(f),
           fit_and_hypotheses_specs(f),
       }) {
    specs.insert(specs.end(), group.begin(), group.end());
  }
  return specs;
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
  // One of `choices`, else Error listing them.
  std::string choice(const std::string& name, const std::vector<std::string>& choices) const;

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
    throw Error(name + " expects a number, got '" + v + "'");
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
    throw Error(name + " expects an integer, got '" + v + "'");
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
  throw Error(name + " expects true or false, got '" + v + "'");
}

std::vector<std::string> Values::list(const std::string& name) const {
  std::vector<std::string> out;
  std::stringstream ss(text(name));
  for (std::string item; std::getline(ss, item, ',');) {
    if (item.empty()) throw Error(name + " has an empty item");
    out.push_back(item);
  }
  return out;
}

std::string Values::choice(const std::string& name, const std::vector<std::string>& choices) const {
  const std::string v = text(name);
  if (std::find(choices.begin(), choices.end(), v) != choices.end()) return v;
  std::string all;
  for (std::size_t i = 0; i < choices.size(); ++i) {
    all += (i == 0 ? "" : i + 1 == choices.size() ? " or " : ", ") + choices[i];
  }
  throw Error(name + " must be " + all + ", got '" + v + "'");
}

void set_sampling(FilterParameters& f, const Values& v) {
  f.initial_particles = v.count("particles", limits::kMaxParticles);
  f.kld.min_particles = v.count("min_particles", limits::kMaxParticles);
  f.kld.max_particles = v.count("max_particles", limits::kMaxParticles);
  f.kld.pf_err = v.number("pf_err");
  f.kld.pf_z = v.number("pf_z");
  f.kld.bin_xy = static_cast<float>(v.number("kld_bin_xy"));
  f.kld.bin_z = static_cast<float>(v.number("kld_bin_z"));
  f.kld.bin_angle = static_cast<float>(v.angle("kld_bin_angle"));
  f.resample_method = parse_resampling_method(v.text("resample_method"));
  f.resample_interval = v.count("resample_interval");
  f.resample_ess_ratio = v.number("resample_ess_ratio");
  f.recovery_alpha_slow = v.number("recovery_alpha_slow");
  f.recovery_alpha_fast = v.number("recovery_alpha_fast");
  f.recovery_margin = v.number("recovery_margin");
  f.min_ess_ratio = v.number("min_ess_ratio");
  f.subset_first.points = v.count("subset_points", limits::kMaxBeams);
  f.subset_first.share = v.number("subset_share");
  f.subset_first.min_particles = v.count("subset_min_particles");
  f.seed = v.count("seed");
}

void set_sensor(FilterParameters& f, const Values& v) {
  f.sensor.sigma_hit = static_cast<float>(v.number("sigma_hit"));
  f.sensor.z_hit = static_cast<float>(v.number("z_hit"));
  f.sensor.z_rand = static_cast<float>(v.number("z_rand"));
  f.sensor.max_range = static_cast<float>(v.positive("laser_max_range"));
  f.sensor.likelihood =
      v.choice("likelihood", {"product", "sum"}) == "product" ? Likelihood::kProduct : Likelihood::kSum;
  f.sensor.interpolation = v.choice("interpolation", {"nearest", "trilinear"}) == "nearest" ? Interpolation::kNearest
                                                                                            : Interpolation::kTrilinear;
  f.sensor.weight_exponent = static_cast<float>(v.number("weight_exponent"));
  f.unknown_as_free = v.choice("unknown_space", {"free", "miss"}) == "free";
}

void set_motion(FilterParameters& f, const Values& v) {
  f.motion.type = parse_motion_model(v.text("motion_model"));
  double* alphas[] = {&f.motion.alpha1, &f.motion.alpha2, &f.motion.alpha3, &f.motion.alpha4,
                      &f.motion.alpha5, &f.motion.alpha6, &f.motion.alpha7, &f.motion.alpha8};
  for (int i = 0; i < 8; ++i) *alphas[i] = v.number("alpha" + std::to_string(i + 1));
  f.motion.imu_rotation = v.flag("imu_rotation");
  f.motion.imu_sigma = v.angle("imu_sigma");
  f.motion.diffusion_xy = v.number("diffusion_xy");
  f.motion.diffusion_z = v.number("diffusion_z");
  f.motion.diffusion_yaw = v.angle("diffusion_yaw");
  f.motion.diffusion_roll_pitch = v.angle("diffusion_roll_pitch");
  f.update_min_d = v.number("update_min_d");
  f.update_min_a = v.angle("update_min_a");
  f.roughening_xyz = v.number("roughening_xyz");
  f.roughening_angle = v.angle("roughening_angle");
  f.roughening_interval = v.number("roughening_interval");
}

void set_initialization(FilterParameters& f, const Values& v) {
  f.global_init.max_tilt = v.angle("init_max_tilt");
  if (v.given("init_height_band")) {
    const std::vector<std::string> band = v.list("init_height_band");
    if (band.size() != 2) throw Error("init_height_band expects MIN,MAX");
    f.global_init.use_height_band = true;
    f.global_init.min_height = Values({{"init_height_band", band[0]}}).number("init_height_band");
    f.global_init.max_height = Values({{"init_height_band", band[1]}}).number("init_height_band");
  }
  f.global_init.min_clearance = v.number("init_min_clearance");
  f.global_search.candidates = v.count("init_candidates", limits::kMaxParticles);
  f.global_search.screen_points = v.count("init_screen_points", limits::kMaxBeams);
  f.global_search.screen_sigma = static_cast<float>(v.number("init_screen_sigma"));
  f.global_search.proposal.uniform_share = v.number("init_uniform_share");
  f.local_init.sigma_xy = v.number("init_sigma_xy");
  f.local_init.sigma_z = v.number("init_sigma_z");
  f.local_init.sigma_yaw = v.angle("init_sigma_yaw");
  f.local_init.sigma_roll_pitch = v.angle("init_sigma_roll_pitch");
}

void set_estimate(FilterParameters& f, const Values& v) {
  f.estimate.best_particle = v.choice("pose_estimate", {"mean", "best"}) == "best";
  f.estimate.cluster_bin_xyz = static_cast<float>(v.number("cluster_bin_xyz"));
  f.estimate.cluster_bin_yaw = static_cast<float>(v.angle("cluster_bin_yaw"));
  f.estimate.converged_weight = v.number("converged_weight");
  f.estimate.converged_std_xyz = v.number("converged_std_xyz");
  f.estimate.converged_std_angle = v.angle("converged_std_angle");
  f.convergence.min_inlier_ratio = v.number("converged_min_inliers");
  f.convergence.min_updates = v.count("converged_min_updates");
  f.convergence.travel_after_jump_m = v.number("converged_travel_after_jump");
  f.convergence.competitor_min_weight = v.number("converged_competitor_weight");
  f.inlier_distance = static_cast<float>(v.number("inlier_distance"));
  f.recovery_min_inliers = v.number("recovery_min_inliers");
  f.hypothesis_evidence_points = v.number("hypothesis_evidence_points");
  f.hypothesis_min_particles = v.count("hypothesis_min_particles", limits::kMaxParticles);
  f.hypothesis_min_weight = v.number("hypothesis_min_weight");
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
    if (items.size() != 6) throw Error("init expects global, initial_pose or x,y,z,roll,pitch,yaw (6 numbers)");
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
  static const std::vector<ParameterSpec> specs = make_specs();
  return specs;
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

LocalizerOptions localizer_options_from(const std::map<std::string, std::string>& values) {
  const Values v(values);
  LocalizerOptions lo;
  set_sampling(lo.filter, v);
  set_sensor(lo.filter, v);
  set_motion(lo.filter, v);
  set_initialization(lo.filter, v);
  set_estimate(lo.filter, v);
  lo.filter.validate();
  lo.preprocessing.laser_min_range = static_cast<float>(v.number("laser_min_range"));
  lo.preprocessing.laser_max_range = static_cast<float>(v.number("laser_max_range"));
  lo.preprocessing.voxel_size = static_cast<float>(v.number("scan_voxel"));
  lo.preprocessing.max_beams = v.count("max_beams", limits::kMaxBeams);
  lo.preprocessing.seed = v.count("seed");
  lo.preprocessing.validate();
  lo.initial_pose = initial_pose(v);
  lo.use_imu = !v.flag("ignore_imu");
  lo.evaluator.backend = parse_backend(v.text("backend"));
  lo.evaluator.cpu_threads = static_cast<int>(v.count("cpu_threads", limits::kMaxThreads));
  lo.evaluator.weight_layout = parse_weight_layout(v.text("weight_layout"));
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
    throw Error(what + " expects an angle (radians, or e.g. 90deg), got '" + text + "'");
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
