// The localizer's parameter table: every parameter's name, default, help and group, in localize --help's order
// (localizer_parameters.hpp reads values against it).
#include "parameter_table.hpp"

#include <sstream>

#include "tsdf_mcl/core/limits.hpp"

namespace tsdf_mcl {
namespace {

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
       "subset first: weigh every particle on K of the scan's points first and only the best subset_share on more "
       "of them, in sets of at least subset_min_particles (0 = off; not on a discrete GPU, where the whole scan is "
       "faster)",
       kAdvanced},
      {"subset_share", "S", num(f.subset_first.share),
       "subset first: share of the particles weighed past the first pass (in the middle pass, or on the whole scan "
       "without one)",
       kAdvanced},
      {"subset_min_particles", "N", std::to_string(f.subset_first.min_particles),
       "subset first: only in sets of at least N particles", kAdvanced},
      {"subset_global_points", "K", std::to_string(f.subset_first.global_points),
       "subset first in a global search (until the belief first concentrates; not after a local start): every "
       "particle on K points first (0 = no middle pass)",
       kAdvanced},
      {"subset_middle_points", "K", std::to_string(f.subset_first.middle_points),
       "subset first in a global search: the best subset_share on K points in a middle pass, and only the best "
       "subset_whole_share on the whole scan (none where K <= subset_global_points or K > half the scan)",
       kAdvanced},
      {"subset_whole_share", "S", num(f.subset_first.whole_share),
       "subset first with a middle pass: share of the particles weighed on the whole scan", kAdvanced},
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
      {"converged_look_alike_nats", "NATS", num(f.look_alikes.refute_nats),
       "converged: no place elsewhere may be left that this much paired evidence summed over the scans since it was "
       "found has not refuted, whatever its share of the belief; 0 = off",
       kAdvanced},
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
      {"wall_tilt_information", "W", num(f.wall_tilt_information),
       "the scan's walls (planar patches within 10 degrees of vertical) hold the tilt of each pose refined onto "
       "the map, each weighing this against 512 points, in proportion to the points (0 = the points alone; 3 "
       "measured, docs/filter.md)",
       kAdvanced},
      {"estimate_switch_ratio", "R", num(f.estimate_switch_ratio),
       "while no place dominates, the estimate moves to another place only once it holds this many times the "
       "share of the place the estimate is on (1 = always the heaviest place)",
       kAdvanced},
      {"hypothesis_evidence_points", "N", num(f.hypothesis_evidence_points),
       "between hypotheses (modes) a scan counts as this many independent points of evidence (0 = untempered)",
       kAdvanced},
      {"decisive_inlier_gap", "G", num(f.decisive_inlier_gap),
       "before the belief first concentrates, a scan counts as up to hypothesis_evidence_points against a compact "
       "place where the map covers nearly all of the scan and the best place explains at least this much more of "
       "it on two updates in a row, as far as it turns the estimate and no further (0 = off: as few points as the "
       "tempering lets)",
       kAdvanced},
      {"sampled_place_shares", "", "",
       "as a global search first names its places, keep the shares its particles held there (off: the places "
       "tied with the best fit start at equal shares, since how many of the uniform start's guesses landed near "
       "each of two identical places is luck, not evidence)",
       kAdvanced},
      {"frontier_evidence", "", "",
       "let points at the frontier of the map's observed space (within a truncation length of space it never "
       "observed) count as evidence between places and between a concentrated cloud's particles (off: they do not)",
       kAdvanced},
      {"see_through_weight", "W", num(f.see_through_weight),
       "a place weighed on the points clear of the frontier also weighs its particles' heights on the scan's rays "
       "where the map holds what the sensor sees below its horizon: a ray through a surface of the map costs this "
       "many times a missed point (0 = off)",
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
}  // namespace

std::vector<ParameterSpec> localizer_parameter_table() {
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

}  // namespace tsdf_mcl
