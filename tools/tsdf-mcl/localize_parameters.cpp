#include "localize_parameters.hpp"

#include <sstream>

#include "tsdf_mcl/error.hpp"
#include "tsdf_mcl/limits.hpp"
#include "parameter_file.hpp"

namespace tsdf_mcl::cli {

// Filter parameters keep nav2 AMCL's names and spelling (underscores) where the meaning carries over, so
// values from a nav2 YAML file move over unchanged; the 6-DoF additions follow the same style. Angles are in
// radians, as in nav2.
std::vector<OptionSpec> localize_parameter_specs() {
  const FilterParameters f;
  const ScanPreprocessing s;
  auto num = [](double v) {
    std::ostringstream out;
    out << v;
    return out.str();
  };
  return {
      {"init", "MODE", "global",
       "global (uniform over the map's free space), x,y,z,roll,pitch,yaw, or initial_pose (the initial_pose.* values)"},
      {"initial_pose.x", "M", "0", "initial pose for --init initial_pose: x"},
      {"initial_pose.y", "M", "0", "... y"},
      {"initial_pose.z", "M", "0", "... z"},
      {"initial_pose.roll", "RAD", "0", "... roll"},
      {"initial_pose.pitch", "RAD", "0", "... pitch"},
      {"initial_pose.yaw", "RAD", "0", "... yaw"},
      {"particles", "N", std::to_string(f.initial_particles), "particles of the initialization (global or local)"},
      {"backend", "NAME", "auto", "sensor update on auto (Vulkan if a device works, else CPU), vulkan or cpu"},
      {"cpu_threads", "N", "0", "threads of the CPU backend (0 = all)"},
      {"weight_layout", "NAME", "auto",
       "vulkan: auto (a subgroup per particle on GPUs, an invocation per particle on CPU devices such as lavapipe), "
       "invocation or subgroup"},
      {"seed", "N", "0", "random seed; results are reproducible for a seed and backend"},
      {"ignore_imu", "", "",
       "do not use the dataset's IMU, imu.txt or a bag's --imu_topic (gravity for the global search, docs/filter.md)"},
      // KLD-sampling and resampling.
      {"min_particles", "N", std::to_string(f.kld.min_particles), "KLD-sampling: fewest particles"},
      {"max_particles", "N", std::to_string(f.kld.max_particles), "KLD-sampling: most particles"},
      {"pf_err", "E", num(f.kld.pf_err), "KLD-sampling: bound on the KL divergence (epsilon)"},
      {"pf_z", "Z", num(f.kld.pf_z),
       "KLD-sampling: upper standard-normal quantile z_(1-delta), a number of standard deviations as in nav2, not a "
       "probability (0.99 -> 84 %, 2.33 -> 99 %)"},
      {"kld_bin_xy", "M", num(f.kld.bin_xy), "KLD-sampling: histogram bin in x and y"},
      {"kld_bin_z", "M", num(f.kld.bin_z), "KLD-sampling: histogram bin in z"},
      {"kld_bin_angle", "RAD", num(f.kld.bin_angle), "KLD-sampling: histogram bin in roll, pitch and yaw"},
      {"resample_method", "NAME", to_string(f.resample_method), "systematic (low variance), residual or multinomial"},
      {"resample_interval", "N", std::to_string(f.resample_interval), "consider resampling every N-th filter update"},
      {"resample_ess_ratio", "R", num(f.resample_ess_ratio),
       "resample when the effective sample size drops below R * particles (1 = always)"},
      {"recovery_alpha_slow", "A", num(f.recovery_alpha_slow),
       "recovery: long-term fit average rate (0 = no recovery)"},
      {"recovery_alpha_fast", "A", num(f.recovery_alpha_fast),
       "recovery: short-term fit average rate (0 = no recovery)"},
      {"recovery_margin", "M", num(f.recovery_margin),
       "recovery: the short-term fit must fall this fraction below the long-term one before random particles come"},
      // Sensor model and scan preprocessing.
      {"sigma_hit", "M", num(f.sensor.sigma_hit), "endpoint model: standard deviation of the distance to the surface"},
      {"z_hit", "W", num(f.sensor.z_hit), "endpoint model: weight of the hit Gaussian"},
      {"z_rand", "W", num(f.sensor.z_rand), "endpoint model: weight of the uniform part (z_rand / laser_max_range)"},
      {"likelihood", "FORM", "product",
       "product (joint likelihood, log domain) or sum (the reference implementation's form)"},
      {"interpolation", "MODE", "nearest", "TSDF lookup: nearest or trilinear"},
      {"weight_exponent", "X", num(f.sensor.weight_exponent),
       "log-weight multiplier: tempers the joint likelihood of correlated points"},
      {"unknown_space", "AS", f.unknown_as_free ? "free" : "miss",
       "a scan point in the map's unknown space counts as one in free space beyond the truncation band (free) or as a "
       "miss, p_rand (miss, the reference implementation)"},
      {"min_ess_ratio", "R", num(f.min_ess_ratio),
       "adaptive tempering: keep at least R * particles effective particles per update (0 = off)"},
      {"subset_points", "K", std::to_string(f.subset_first.points),
       "subset first: weigh every particle on K of the scan's points first and only the best subset_share on all "
       "of them, in sets of at least subset_min_particles (0 = off)"},
      {"subset_share", "S", num(f.subset_first.share),
       "subset first: share of the particles weighed on the whole scan"},
      {"subset_min_particles", "N", std::to_string(f.subset_first.min_particles),
       "subset first: only in sets of at least N particles"},
      {"laser_min_range", "M", num(s.laser_min_range), "drop scan points closer than this"},
      {"laser_max_range", "M", num(s.laser_max_range), "drop scan points farther than this"},
      {"scan_voxel", "M", num(s.voxel_size), "thin the scan to one point per voxel of this size (0 = off)"},
      {"max_beams", "N", std::to_string(s.max_beams),
       "points per scan used in the sensor update, spread over the whole scan"},
      // Motion.
      {"motion_model", "NAME", to_string(f.motion.type), "odometry (odom.txt), constant_velocity or diffusion"},
      {"alpha1", "A", num(f.motion.alpha1), "yaw noise from rotation (rad/rad)"},
      {"alpha2", "A", num(f.motion.alpha2), "yaw noise from translation (rad/m)"},
      {"alpha3", "A", num(f.motion.alpha3), "along-track translation noise from translation (m/m)"},
      {"alpha4", "A", num(f.motion.alpha4), "translation noise from rotation (m/rad)"},
      {"alpha5", "A", num(f.motion.alpha5), "cross-track translation noise from translation (m/m)"},
      {"alpha6", "A", num(f.motion.alpha6), "vertical (sensor z) translation noise from translation (m/m)"},
      {"alpha7", "A", num(f.motion.alpha7), "roll/pitch noise from rotation (rad/rad)"},
      {"alpha8", "A", num(f.motion.alpha8), "roll/pitch noise from translation (rad/m)"},
      {"imu_rotation", "", "",
       "trust the odometry's relative rotation (IMU): rotation noise imu_sigma instead of alpha1/2/7/8"},
      {"imu_sigma", "RAD", num(f.motion.imu_sigma), "rotation noise per update with --imu_rotation"},
      {"diffusion_xy", "M", num(f.motion.diffusion_xy), "random walk of constant_velocity/diffusion, per sqrt(s)"},
      {"diffusion_z", "M", num(f.motion.diffusion_z), "... in z"},
      {"diffusion_yaw", "RAD", num(f.motion.diffusion_yaw), "... in yaw"},
      {"diffusion_roll_pitch", "RAD", num(f.motion.diffusion_roll_pitch), "... in roll and pitch"},
      {"update_min_d", "M", num(f.update_min_d), "filter update only after this much translation (odometry model)"},
      {"update_min_a", "RAD", num(f.update_min_a), "... or this much rotation"},
      {"roughening_xyz", "M", num(f.roughening_xyz),
       "until the first convergence: extra random walk per update and axis"},
      {"roughening_angle", "RAD", num(f.roughening_angle), "... and per rotation axis"},
      {"roughening_interval", "S", num(f.roughening_interval),
       "until the first convergence: an update at least this often, moving or not"},
      // Initialization.
      {"init_max_tilt", "RAD", num(f.global_init.max_tilt),
       "global init: sensor z axis within this angle of the world's (gravity known); pi = any rotation"},
      {"init_height_band", "MIN,MAX", "",
       "global init: sensor height above the floor below it (ground robot), e.g. 0.3,1.5"},
      {"init_min_clearance", "M", num(f.global_init.min_clearance), "global init: minimum distance from surfaces"},
      {"init_candidates", "N", std::to_string(f.global_search.candidates),
       "global init: hypotheses drawn from the first scan's up-direction and height candidates and scored; the best "
       "--particles are kept"},
      {"init_screen_points", "N", std::to_string(f.global_search.screen_points),
       "global init: scan points each hypothesis is scored on"},
      {"init_screen_sigma", "M", num(f.global_search.screen_sigma),
       "global init: endpoint-model sigma of that scoring (wide: hypotheses a little off still score)"},
      {"init_uniform_share", "R", num(f.global_search.proposal.uniform_share),
       "global init and recovery: share of hypotheses uniform over free space and rotations (the rest follow the "
       "scan's up and floor height)"},
      {"init_sigma_xy", "M", num(f.local_init.sigma_xy), "local init: position spread in x and y"},
      {"init_sigma_z", "M", num(f.local_init.sigma_z), "local init: spread in z"},
      {"init_sigma_yaw", "RAD", num(f.local_init.sigma_yaw), "local init: yaw spread"},
      {"init_sigma_roll_pitch", "RAD", num(f.local_init.sigma_roll_pitch), "local init: roll and pitch spread"},
      // Pose estimate.
      {"pose_estimate", "MODE", "mean", "mean (weighted mean of the dominant mode) or best (highest-weight particle)"},
      {"cluster_bin_xyz", "M", num(f.estimate.cluster_bin_xyz), "mode finding: grid cell size in x, y, z"},
      {"cluster_bin_yaw", "RAD", num(f.estimate.cluster_bin_yaw), "mode finding: grid cell size in yaw"},
      {"converged_weight", "W", num(f.estimate.converged_weight),
       "converged: share of weight in the dominant mode at least this"},
      {"converged_std_xyz", "M", num(f.estimate.converged_std_xyz),
       "converged: position standard deviation at most this"},
      {"converged_std_angle", "RAD", num(f.estimate.converged_std_angle),
       "converged: rotation standard deviation at most this"},
      {"converged_min_inliers", "R", num(f.convergence.min_inlier_ratio),
       "converged: at least this share of the scan's points within inlier_distance of a surface at the estimate"},
      {"converged_competitor_weight", "W", num(f.convergence.competitor_min_weight),
       "converged: no other hypothesis holding this much of the belief may fit the scan nearly as well (within 0.1 "
       "inlier ratio)"},
      {"converged_min_updates", "N", std::to_string(f.convergence.min_updates),
       "converged: all of the above for this many consecutive filter updates at one place"},
      {"converged_travel_after_jump", "M", num(f.convergence.travel_after_jump_m),
       "converged: after the estimate jumped away from a place it had converged at or concentrated on, or after a "
       "wrong lock was found out, the new place must hold over this much travel first"},
      {"inlier_distance", "M", num(f.inlier_distance),
       "a scan point within this distance of a surface is an inlier (the absolute fit measure)"},
      {"recovery_min_inliers", "R", num(f.recovery_min_inliers),
       "recovery: a concentrated belief whose inlier ratio stays below this is a wrong lock and searches again (0 = "
       "off)"},
      {"hypothesis_evidence_points", "N", num(f.hypothesis_evidence_points),
       "between hypotheses (modes) a scan counts as this many independent points of evidence (0 = untempered)"},
      {"hypothesis_min_particles", "N", std::to_string(f.hypothesis_min_particles),
       "each hypothesis with at least hypothesis_min_weight keeps this many particles through resampling"},
      {"hypothesis_min_weight", "W", num(f.hypothesis_min_weight),
       "... hypotheses lighter than this take their chances with the rest"},
  };
}

void apply_config(Options& o, const std::string& file) {
  for (const auto& [name, value] : read_parameter_file(file)) {
    if (name == "config") throw Error(file + ": a config file cannot name another (config)");
    try {
      o.set_default_from_config(name, value);
    } catch (const Error&) {
      throw Error(file + ": unknown parameter '" + name + "' (see tsdf-mcl localize --help)");
    }
  }
}

namespace {

double positive(const Options& o, const std::string& name) {
  const double v = o.number(name);
  if (!(v > 0.0)) throw Error("--" + name + " must be positive");
  return v;
}

}  // namespace

FilterParameters filter_parameters(const Options& o) {
  FilterParameters f;
  f.initial_particles = o.count("particles", limits::kMaxParticles);
  f.kld.min_particles = o.count("min_particles", limits::kMaxParticles);
  f.kld.max_particles = o.count("max_particles", limits::kMaxParticles);
  f.kld.pf_err = o.number("pf_err");
  f.kld.pf_z = o.number("pf_z");
  f.kld.bin_xy = static_cast<float>(o.number("kld_bin_xy"));
  f.kld.bin_z = static_cast<float>(o.number("kld_bin_z"));
  f.kld.bin_angle = static_cast<float>(o.number("kld_bin_angle"));
  f.resample_method = parse_resampling_method(o.text("resample_method"));
  f.resample_interval = o.count("resample_interval");
  f.resample_ess_ratio = o.number("resample_ess_ratio");
  f.recovery_alpha_slow = o.number("recovery_alpha_slow");
  f.recovery_alpha_fast = o.number("recovery_alpha_fast");
  f.recovery_margin = o.number("recovery_margin");

  f.sensor.sigma_hit = static_cast<float>(o.number("sigma_hit"));
  f.sensor.z_hit = static_cast<float>(o.number("z_hit"));
  f.sensor.z_rand = static_cast<float>(o.number("z_rand"));
  f.sensor.max_range = static_cast<float>(positive(o, "laser_max_range"));
  const std::string likelihood = o.text("likelihood");
  if (likelihood != "product" && likelihood != "sum") throw Error("--likelihood must be product or sum");
  f.sensor.likelihood = likelihood == "product" ? Likelihood::kProduct : Likelihood::kSum;
  const std::string interpolation = o.text("interpolation");
  if (interpolation != "nearest" && interpolation != "trilinear") {
    throw Error("--interpolation must be nearest or trilinear");
  }
  f.sensor.interpolation = interpolation == "nearest" ? Interpolation::kNearest : Interpolation::kTrilinear;
  f.sensor.weight_exponent = static_cast<float>(o.number("weight_exponent"));
  const std::string unknown_space = o.text("unknown_space");
  if (unknown_space != "free" && unknown_space != "miss") throw Error("--unknown_space must be free or miss");
  f.unknown_as_free = unknown_space == "free";
  f.min_ess_ratio = o.number("min_ess_ratio");
  f.subset_first.points = o.count("subset_points", limits::kMaxBeams);
  f.subset_first.share = o.number("subset_share");
  f.subset_first.min_particles = o.count("subset_min_particles");

  f.motion.type = parse_motion_model(o.text("motion_model"));
  f.motion.alpha1 = o.number("alpha1");
  f.motion.alpha2 = o.number("alpha2");
  f.motion.alpha3 = o.number("alpha3");
  f.motion.alpha4 = o.number("alpha4");
  f.motion.alpha5 = o.number("alpha5");
  f.motion.alpha6 = o.number("alpha6");
  f.motion.alpha7 = o.number("alpha7");
  f.motion.alpha8 = o.number("alpha8");
  f.motion.imu_rotation = o.flag("imu_rotation");
  f.motion.imu_sigma = o.number("imu_sigma");
  f.motion.diffusion_xy = o.number("diffusion_xy");
  f.motion.diffusion_z = o.number("diffusion_z");
  f.motion.diffusion_yaw = o.number("diffusion_yaw");
  f.motion.diffusion_roll_pitch = o.number("diffusion_roll_pitch");
  f.update_min_d = o.number("update_min_d");
  f.update_min_a = o.number("update_min_a");
  f.roughening_xyz = o.number("roughening_xyz");
  f.roughening_angle = o.number("roughening_angle");
  f.roughening_interval = o.number("roughening_interval");

  f.global_init.max_tilt = o.number("init_max_tilt");
  if (o.maybe("init_height_band")) {
    const std::vector<double> band = o.numbers("init_height_band");
    if (band.size() != 2) throw Error("--init_height_band expects MIN,MAX");
    f.global_init.use_height_band = true;
    f.global_init.min_height = band[0];
    f.global_init.max_height = band[1];
  }
  f.global_init.min_clearance = o.number("init_min_clearance");
  f.global_search.candidates = o.count("init_candidates", limits::kMaxParticles);
  f.global_search.screen_points = o.count("init_screen_points", limits::kMaxBeams);
  f.global_search.screen_sigma = static_cast<float>(o.number("init_screen_sigma"));
  f.global_search.proposal.uniform_share = o.number("init_uniform_share");
  f.local_init.sigma_xy = o.number("init_sigma_xy");
  f.local_init.sigma_z = o.number("init_sigma_z");
  f.local_init.sigma_yaw = o.number("init_sigma_yaw");
  f.local_init.sigma_roll_pitch = o.number("init_sigma_roll_pitch");

  const std::string estimate = o.text("pose_estimate");
  if (estimate != "mean" && estimate != "best") throw Error("--pose_estimate must be mean or best");
  f.estimate.best_particle = estimate == "best";
  f.estimate.cluster_bin_xyz = static_cast<float>(o.number("cluster_bin_xyz"));
  f.estimate.cluster_bin_yaw = static_cast<float>(o.number("cluster_bin_yaw"));
  f.estimate.converged_weight = o.number("converged_weight");
  f.estimate.converged_std_xyz = o.number("converged_std_xyz");
  f.estimate.converged_std_angle = o.number("converged_std_angle");
  f.convergence.min_inlier_ratio = o.number("converged_min_inliers");
  f.convergence.min_updates = o.count("converged_min_updates");
  f.convergence.travel_after_jump_m = o.number("converged_travel_after_jump");
  f.convergence.competitor_min_weight = o.number("converged_competitor_weight");
  f.inlier_distance = static_cast<float>(o.number("inlier_distance"));
  f.recovery_min_inliers = o.number("recovery_min_inliers");
  f.hypothesis_evidence_points = o.number("hypothesis_evidence_points");
  f.hypothesis_min_particles = o.count("hypothesis_min_particles", limits::kMaxParticles);
  f.hypothesis_min_weight = o.number("hypothesis_min_weight");
  f.seed = o.count("seed");
  f.validate();
  return f;
}

ScanPreprocessing scan_parameters(const Options& o) {
  ScanPreprocessing s;
  s.laser_min_range = static_cast<float>(o.number("laser_min_range"));
  s.laser_max_range = static_cast<float>(o.number("laser_max_range"));
  s.voxel_size = static_cast<float>(o.number("scan_voxel"));
  s.max_beams = o.count("max_beams", limits::kMaxBeams);
  s.seed = o.count("seed");
  s.validate();
  return s;
}

// The initial pose of --init x,y,z,roll,pitch,yaw or --init initial_pose; nullopt for global.
std::optional<Pose> initial_pose(const Options& o) {
  const std::string init = o.text("init");
  if (init == "global") return std::nullopt;
  std::vector<double> v;
  if (init == "initial_pose") {
    for (const char* k : {"x", "y", "z", "roll", "pitch", "yaw"})
      v.push_back(o.number(std::string("initial_pose.") + k));
  } else {
    v = o.numbers("init");
    if (v.size() != 6) throw Error("--init expects global, initial_pose or x,y,z,roll,pitch,yaw (6 numbers)");
  }
  return pose_from_xyz_rpy(v[0], v[1], v[2], v[3], v[4], v[5]);
}

LocalizerOptions localizer_options(const Options& o) {
  LocalizerOptions lo;
  lo.filter = filter_parameters(o);
  lo.preprocessing = scan_parameters(o);
  lo.initial_pose = initial_pose(o);
  lo.use_imu = !o.flag("ignore_imu");
  lo.evaluator.backend = parse_backend(o.text("backend"));
  lo.evaluator.cpu_threads = static_cast<int>(o.count("cpu_threads", limits::kMaxThreads));
  lo.evaluator.weight_layout = parse_weight_layout(o.text("weight_layout"));
  return lo;
}

}  // namespace tsdf_mcl::cli
