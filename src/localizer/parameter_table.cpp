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

// localize --help's sections (ParameterSpec::group); --help-all adds the expert ones.
const char* const kInit = "initialization";
const char* const kFilter = "filter";
const char* const kSensor = "sensor model";
const char* const kDecision = "decision";
const char* const kRuntime = "runtime";
const char* const kExpert = "expert";

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
      {"init_sigma_xy", "M", num(f.local_init.sigma_xy), "local init: position spread in x and y", kInit},
      {"init_sigma_yaw", "RAD", num(f.local_init.sigma_yaw), "local init: yaw spread", kInit},
      {"init_sigma_z", "M", num(f.local_init.sigma_z),
       "local init: spread in z (roll and pitch spread: a fifth of init_sigma_yaw)", kExpert},
      {"init_max_tilt", "RAD", num(f.global_init.max_tilt),
       "global init: sensor z axis within this angle of the world's (gravity known); pi = any rotation", kExpert},
      {"init_candidates", "N", std::to_string(f.global_search.candidates),
       "global init: hypotheses drawn from the first scan's up-direction and height candidates and scored; the best "
       "--particles are kept",
       kExpert},
      {"ignore_imu", "", "",
       "do not use the dataset's IMU, imu.txt or a bag's --imu_topic (gravity for the global search)", kExpert},
  };
}

// Particle counts, resampling, recovery and the motion model (nav2 AMCL's names).
std::vector<ParameterSpec> filter_specs(const FilterParameters& f) {
  return {
      {"min_particles", "N", std::to_string(f.kld.min_particles), "KLD-sampling: fewest particles", kFilter},
      {"max_particles", "N", std::to_string(f.kld.max_particles), "KLD-sampling: most particles", kFilter},
      {"pf_err", "E", num(f.kld.pf_err), "KLD-sampling: bound on the KL divergence (epsilon)", kFilter},
      {"pf_z", "Z", num(f.kld.pf_z),
       "KLD-sampling: upper standard-normal quantile z_(1-delta), a number of standard deviations as in nav2, not "
       "a probability (0.99 -> 84 %, 2.33 -> 99 %)",
       kFilter},
      {"resample_interval", "N", std::to_string(f.resample_interval), "consider resampling every N-th filter update",
       kFilter},
      {"recovery_alpha_slow", "A", num(f.recovery.alpha_slow), "recovery: long-term fit average rate (0 = no recovery)",
       kFilter},
      {"recovery_alpha_fast", "A", num(f.recovery.alpha_fast),
       "recovery: short-term fit average rate (0 = no recovery)", kFilter},
      {"motion_model", "NAME", to_string(f.motion.type), "odometry (odom.txt), constant_velocity or diffusion",
       kFilter},
      {"update_min_d", "M", num(f.update_min_d), "filter update only after this much translation (odometry model)",
       kFilter},
      {"update_min_a", "RAD", num(f.update_min_a), "... or this much rotation", kFilter},
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
      {"alpha6", "A", num(f.motion.alpha6), "vertical (sensor z) translation noise from translation (m/m)", kExpert},
      {"alpha7", "A", num(f.motion.alpha7), "roll/pitch noise from rotation (rad/rad)", kExpert},
      {"alpha8", "A", num(f.motion.alpha8), "roll/pitch noise from translation (rad/m)", kExpert},
      {"imu_rotation_sigma", "RAD", "0",
       "trust the odometry's relative rotation (an IMU's) with this rotation noise per update instead of "
       "alpha1/2/7/8 (0 = off)",
       kExpert},
      {"diffusion_xy", "M", num(f.motion.diffusion_xy),
       "random walk of constant_velocity and diffusion per sqrt(s) in x and y (in z a quarter of it)", kExpert},
      {"diffusion_yaw", "RAD", num(f.motion.diffusion_yaw), "... in yaw (in roll and pitch 0.3 times it)", kExpert},
  };
}

// Sensor model and scan preprocessing.
std::vector<ParameterSpec> sensor_model_specs(const FilterParameters& f, const ScanPreprocessing& s) {
  return {
      {"laser_min_range", "M", num(s.laser_min_range), "drop scan points closer than this", kSensor},
      {"laser_max_range", "M", num(s.laser_max_range), "drop scan points farther than this", kSensor},
      {"max_beams", "N", std::to_string(s.max_beams),
       "points per scan used in the sensor update, spread over the whole scan", kSensor},
      {"sigma_hit", "M", num(f.sensor.sigma_hit), "endpoint model: standard deviation of the distance to the surface",
       kSensor},
      {"z_hit", "W", num(f.sensor.z_hit), "endpoint model: weight of the hit Gaussian", kSensor},
      {"z_rand", "W", num(f.sensor.z_rand), "endpoint model: weight of the uniform part (z_rand / laser_max_range)",
       kSensor},
      {"scan_voxel", "M", num(s.voxel_size), "thin the scan to one point per voxel of this size (0 = off)", kExpert},
  };
}

// The decision between places and the state a robot reads (docs/filter.md, "The ledger", "States").
std::vector<ParameterSpec> decision_specs(const FilterParameters& f) {
  return {
      {"evidence_nats", "NATS", num(f.ledger.decide_nats),
       "the ledger's threshold: a look-alike is refuted (or proven better than the track) once the scans since it "
       "was found favour one of the two by this much (0 = off: no look-alike holds converged back)",
       kDecision},
      {"proof_travel", "M", num(f.ledger.window_m),
       "a look-alike is proven better than the track only over this much travel, and by the scans within it",
       kDecision},
      {"converged_min_inliers", "R", num(f.states.min_inliers),
       "converged is entered only where at least this share of the scan's observed points lies within 0.2 m of a "
       "surface at the estimate",
       kDecision},
      {"recovery_min_inliers", "R", num(f.recovery.min_inliers),
       "a concentrated belief whose inlier ratio stays below this is a wrong lock: the filter searches again "
       "(0 = off)",
       kExpert},
  };
}

// Where and how the sensor update runs, and the random seed.
std::vector<ParameterSpec> runtime_specs() {
  return {
      {"backend", "NAME", "auto", "sensor update on auto (Vulkan if a device works, else CPU), vulkan or cpu",
       kRuntime},
      {"seed", "N", "0", "random seed; results are reproducible for a seed and backend", kRuntime},
      {"cpu_threads", "N", "0", "threads of the CPU backend (0 = all)", kExpert},
  };
}

// Filter parameters keep nav2 AMCL's names and spelling (underscores) where the meaning carries over, so values from a
// nav2 YAML file move over unchanged; the 6-DoF additions follow the same style. Angles in radians as in nav2 (RAD),
// or with a deg/rad suffix. Everything else the filter has is a design constant of its options structs
// (filter_parameters.hpp), documented in docs/filter.md.
}  // namespace

std::vector<ParameterSpec> localizer_parameter_table() {
  const FilterParameters f;
  const ScanPreprocessing s;
  std::vector<ParameterSpec> specs;
  for (const std::vector<ParameterSpec>& group : {
           initialization_specs(f),
           filter_specs(f),
           motion_noise_specs(f),
           sensor_model_specs(f, s),
           decision_specs(f),
           runtime_specs(),
       }) {
    specs.insert(specs.end(), group.begin(), group.end());
  }
  return specs;
}

}  // namespace tsdf_mcl
