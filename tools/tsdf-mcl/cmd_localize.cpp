#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "options.hpp"
#include "tsdf_mcl/dataset.hpp"
#include "tsdf_mcl/error.hpp"
#include "tsdf_mcl/map_io.hpp"
#include "tsdf_mcl/particle_filter.hpp"
#include "tsdf_mcl/particle_snapshot.hpp"
#include "tsdf_mcl/scan_preprocessing.hpp"
#include "tsdf_mcl/sensor_evaluator.hpp"

namespace tsdf_mcl::cli {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
constexpr double kDeg = 57.29577951308232;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// Filter parameters keep nav2 AMCL's names and spelling (underscores) where the meaning carries over, so
// values from a nav2 YAML file move over unchanged; the 6-DoF additions follow the same style. Angles are in
// radians, as in nav2.
std::vector<OptionSpec> localize_options() {
  const FilterParameters f;
  const ScanPreprocessing s;
  auto num = [](double v) {
    std::ostringstream out;
    out << v;
    return out.str();
  };
  return {
      {"map", "FILE", "", "TSDF map (tsdf-mcl build-map)"},
      {"dataset", "DIR", "", "dataset: scans/, times.txt, odom.txt (poses.txt is not used)"},
      {"output", "DIR", "", "output folder for trajectory.tum and report.json"},
      {"start", "S", "0", "first scan"},
      {"stride", "K", "1", "take every K-th scan"},
      {"count", "N", "0", "number of scans (0 = all from start)"},
      {"config", "FILE", "", "YAML or JSON file of parameters by their option names (nested maps join with '.'); command-line flags win"},
      {"init", "MODE", "global", "global (uniform over the map's free space), x,y,z,roll,pitch,yaw, or initial_pose (the initial_pose.* values)"},
      {"initial_pose.x", "M", "0", "initial pose for --init initial_pose: x"},
      {"initial_pose.y", "M", "0", "... y"},
      {"initial_pose.z", "M", "0", "... z"},
      {"initial_pose.roll", "RAD", "0", "... roll"},
      {"initial_pose.pitch", "RAD", "0", "... pitch"},
      {"initial_pose.yaw", "RAD", "0", "... yaw"},
      {"particles", "N", std::to_string(f.initial_particles), "particles of the initialization (global or local)"},
      {"backend", "NAME", "auto", "sensor update on auto (Vulkan if a device works, else CPU), vulkan or cpu"},
      {"cpu_threads", "N", "0", "threads of the CPU backend (0 = all)"},
      {"seed", "N", "0", "random seed; results are reproducible for a seed and backend"},
      {"snapshot_every", "K", "0", "write the particle set to OUT/snapshots/ after initialization and every K-th scan (0 = never), for tsdf-mcl render --particles"},
      // KLD-sampling and resampling.
      {"min_particles", "N", std::to_string(f.kld.min_particles), "KLD-sampling: fewest particles"},
      {"max_particles", "N", std::to_string(f.kld.max_particles), "KLD-sampling: most particles"},
      {"pf_err", "E", num(f.kld.pf_err), "KLD-sampling: bound on the KL divergence (epsilon)"},
      {"pf_z", "Z", num(f.kld.pf_z), "KLD-sampling: upper standard-normal quantile z_(1-delta), a number of standard deviations as in nav2, not a probability (0.99 -> 84 %, 2.33 -> 99 %)"},
      {"kld_bin_xy", "M", num(f.kld.bin_xy), "KLD-sampling: histogram bin in x and y"},
      {"kld_bin_z", "M", num(f.kld.bin_z), "KLD-sampling: histogram bin in z"},
      {"kld_bin_angle", "RAD", num(f.kld.bin_angle), "KLD-sampling: histogram bin in roll, pitch and yaw"},
      {"resample_method", "NAME", to_string(f.resample_method), "systematic (low variance), residual or multinomial"},
      {"resample_interval", "N", std::to_string(f.resample_interval), "consider resampling every N-th filter update"},
      {"resample_ess_ratio", "R", num(f.resample_ess_ratio), "resample when the effective sample size drops below R * particles (1 = always)"},
      {"recovery_alpha_slow", "A", num(f.recovery_alpha_slow), "recovery: long-term fit average rate (0 = no recovery)"},
      {"recovery_alpha_fast", "A", num(f.recovery_alpha_fast), "recovery: short-term fit average rate (0 = no recovery)"},
      {"recovery_margin", "M", num(f.recovery_margin), "recovery: the short-term fit must fall this fraction below the long-term one before random particles come"},
      // Sensor model and scan preprocessing.
      {"sigma_hit", "M", num(f.sensor.sigma_hit), "endpoint model: standard deviation of the distance to the surface"},
      {"z_hit", "W", num(f.sensor.z_hit), "endpoint model: weight of the hit Gaussian"},
      {"z_rand", "W", num(f.sensor.z_rand), "endpoint model: weight of the uniform part (z_rand / laser_max_range)"},
      {"likelihood", "FORM", "product", "product (joint likelihood, log domain) or sum (the reference implementation's form)"},
      {"interpolation", "MODE", "nearest", "TSDF lookup: nearest or trilinear"},
      {"weight_exponent", "X", num(f.sensor.weight_exponent), "log-weight multiplier: tempers the joint likelihood of correlated points"},
      {"min_ess_ratio", "R", num(f.min_ess_ratio), "adaptive tempering: keep at least R * particles effective particles per update (0 = off)"},
      {"laser_min_range", "M", num(s.laser_min_range), "drop scan points closer than this"},
      {"laser_max_range", "M", num(s.laser_max_range), "drop scan points farther than this"},
      {"scan_voxel", "M", num(s.voxel_size), "thin the scan to one point per voxel of this size (0 = off)"},
      {"max_beams", "N", std::to_string(s.max_beams), "points per scan used in the sensor update, spread over the whole scan"},
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
      {"imu_rotation", "", "", "trust the odometry's relative rotation (IMU): rotation noise imu_sigma instead of alpha1/2/7/8"},
      {"imu_sigma", "RAD", num(f.motion.imu_sigma), "rotation noise per update with --imu_rotation"},
      {"diffusion_xy", "M", num(f.motion.diffusion_xy), "random walk of constant_velocity/diffusion, per sqrt(s)"},
      {"diffusion_z", "M", num(f.motion.diffusion_z), "... in z"},
      {"diffusion_yaw", "RAD", num(f.motion.diffusion_yaw), "... in yaw"},
      {"diffusion_roll_pitch", "RAD", num(f.motion.diffusion_roll_pitch), "... in roll and pitch"},
      {"update_min_d", "M", num(f.update_min_d), "filter update only after this much translation (odometry model)"},
      {"update_min_a", "RAD", num(f.update_min_a), "... or this much rotation"},
      {"roughening_xyz", "M", num(f.roughening_xyz), "until the first convergence: extra random walk per update and axis"},
      {"roughening_angle", "RAD", num(f.roughening_angle), "... and per rotation axis"},
      {"roughening_interval", "S", num(f.roughening_interval), "until the first convergence: an update at least this often, moving or not"},
      // Initialization.
      {"init_max_tilt", "RAD", num(f.global_init.max_tilt), "global init: sensor z axis within this angle of the world's (gravity known); pi = any rotation"},
      {"init_height_band", "MIN,MAX", "", "global init: sensor height above the floor below it (ground robot), e.g. 0.3,1.5"},
      {"init_min_clearance", "M", num(f.global_init.min_clearance), "global init: minimum distance from surfaces"},
      {"init_sigma_xy", "M", num(f.local_init.sigma_xy), "local init: position spread in x and y"},
      {"init_sigma_z", "M", num(f.local_init.sigma_z), "local init: spread in z"},
      {"init_sigma_yaw", "RAD", num(f.local_init.sigma_yaw), "local init: yaw spread"},
      {"init_sigma_roll_pitch", "RAD", num(f.local_init.sigma_roll_pitch), "local init: roll and pitch spread"},
      // Pose estimate.
      {"pose_estimate", "MODE", "mean", "mean (weighted mean of the dominant mode) or best (highest-weight particle)"},
      {"cluster_bin_xyz", "M", num(f.estimate.cluster_bin_xyz), "mode finding: grid cell size in x, y, z"},
      {"cluster_bin_yaw", "RAD", num(f.estimate.cluster_bin_yaw), "mode finding: grid cell size in yaw"},
      {"converged_weight", "W", num(f.estimate.converged_weight), "converged: share of weight in the dominant mode at least this"},
      {"converged_std_xyz", "M", num(f.estimate.converged_std_xyz), "converged: position standard deviation at most this"},
      {"converged_std_angle", "RAD", num(f.estimate.converged_std_angle), "converged: rotation standard deviation at most this"},
  };
}

// Flattens a YAML/JSON document into option values: {a: {b: 1}} -> a.b = "1", lists -> "x,y,z".
void flatten(const YAML::Node& node, const std::string& prefix, std::vector<std::pair<std::string, std::string>>& out,
             const std::string& file) {
  if (node.IsMap()) {
    for (const auto& kv : node) {
      const std::string key = kv.first.as<std::string>();
      flatten(kv.second, prefix.empty() ? key : prefix + "." + key, out, file);
    }
  } else if (node.IsSequence()) {
    std::string joined;
    for (const auto& item : node) {
      if (!item.IsScalar()) throw Error(file + ": " + prefix + ": lists may only hold numbers or words");
      joined += (joined.empty() ? "" : ",") + item.as<std::string>();
    }
    out.emplace_back(prefix, joined);
  } else if (node.IsScalar()) {
    out.emplace_back(prefix, node.as<std::string>());
  } else {
    throw Error(file + ": " + prefix + " has no value");
  }
}

void apply_config(Options& o, const std::string& file) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    throw Error("cannot open config file " + file);
  } catch (const YAML::Exception& e) {
    throw Error(file + ": not valid YAML/JSON: " + e.what());
  }
  if (!root.IsMap()) throw Error(file + ": expected a map of parameter names to values");
  std::vector<std::pair<std::string, std::string>> values;
  flatten(root, "", values, file);
  for (const auto& [name, value] : values) {
    if (name == "config") throw Error(file + ": a config file cannot name another (config)");
    try {
      o.set_default_from_config(name, value);
    } catch (const Error&) {
      throw Error(file + ": unknown parameter '" + name + "' (see tsdf-mcl localize --help)");
    }
  }
}

double positive(const Options& o, const std::string& name) {
  const double v = o.number(name);
  if (!(v > 0.0)) throw Error("--" + name + " must be positive");
  return v;
}

FilterParameters filter_parameters(const Options& o) {
  FilterParameters f;
  f.initial_particles = o.count("particles");
  f.kld.min_particles = o.count("min_particles");
  f.kld.max_particles = o.count("max_particles");
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
  f.min_ess_ratio = o.number("min_ess_ratio");

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
  f.seed = o.count("seed");
  f.validate();
  return f;
}

ScanPreprocessing scan_parameters(const Options& o) {
  ScanPreprocessing s;
  s.laser_min_range = static_cast<float>(o.number("laser_min_range"));
  s.laser_max_range = static_cast<float>(o.number("laser_max_range"));
  s.voxel_size = static_cast<float>(o.number("scan_voxel"));
  s.max_beams = o.count("max_beams");
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
    for (const char* k : {"x", "y", "z", "roll", "pitch", "yaw"}) v.push_back(o.number(std::string("initial_pose.") + k));
  } else {
    v = o.numbers("init");
    if (v.size() != 6) throw Error("--init expects global, initial_pose or x,y,z,roll,pitch,yaw (6 numbers)");
  }
  return pose_from_xyz_rpy(v[0], v[1], v[2], v[3], v[4], v[5]);
}

nlohmann::json pose_json(const Pose& p) {
  const Eigen::Quaterniond q(p.linear());
  const Eigen::Vector3d rpy = rpy_of(p.linear());
  const Eigen::Vector3d t = p.translation();
  return {{"x", t.x()}, {"y", t.y()}, {"z", t.z()}, {"qx", q.x()}, {"qy", q.y()}, {"qz", q.z()}, {"qw", q.w()},
          {"roll_deg", rpy.x() * kDeg}, {"pitch_deg", rpy.y() * kDeg}, {"yaw_deg", rpy.z() * kDeg}};
}

void write_snapshot(const ParticleFilter& filter, const fs::path& file) {
  const ParticleArrays p = filter.particles();
  const std::vector<double> w = filter.particle_weights();
  ParticleSnapshot snapshot;
  snapshot.particles.resize(w.size());
  for (std::size_t i = 0; i < w.size(); ++i) {
    snapshot.particles[i].position = p.position(i);
    snapshot.particles[i].orientation = p.rotation(i);
    snapshot.particles[i].weight = static_cast<float>(w[i]);
  }
  write_particle_snapshot(file, snapshot);
}

// NaN (no GPU timestamps) is not valid JSON.
nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

// Every option's effective value, numbers as numbers.
nlohmann::json parameters_json(const Options& o) {
  nlohmann::json j = nlohmann::json::object();
  for (const OptionSpec& s : o.specs()) {
    if (s.value_name.empty()) {
      j[s.name] = o.flag(s.name);
      continue;
    }
    const auto v = o.maybe(s.name);
    if (!v) {
      j[s.name] = nullptr;
      continue;
    }
    char* end = nullptr;
    const double d = std::strtod(v->c_str(), &end);
    if (!v->empty() && *end == '\0' && std::isfinite(d)) j[s.name] = d;
    else j[s.name] = *v;
  }
  return j;
}

}  // namespace

int run_localize(int argc, char** argv) {
  Options o("localize",
            "tsdf-mcl localize --map MAP --dataset DIR [--start S --stride K --count N] [--particles N]\n"
            "                       [--init global|x,y,z,roll,pitch,yaw|initial_pose] [--backend auto|vulkan|cpu] [--seed N]\n"
            "                       [--config FILE] [filter parameters] -o OUT\n"
            "Writes OUT/trajectory.tum (one line per scan, world_T_sensor) and OUT/report.json. Angles in radians.",
            localize_options(), argc, argv, 2);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  o.expect_positional(0, "no positional arguments");
  if (const auto config = o.maybe("config")) apply_config(o, *config);

  const FilterParameters params = filter_parameters(o);
  const ScanPreprocessing scan_params = scan_parameters(o);
  const std::optional<Pose> init_pose = initial_pose(o);
  if (!o.maybe("output")) throw Error("missing -o OUT (the output folder)");
  const fs::path out_dir = o.text("output");
  const std::string map_file = o.text("map");
  const Dataset dataset = Dataset::open(o.text("dataset"));
  ScanSelection selection;
  selection.start = o.count("start");
  selection.stride = o.count("stride");
  selection.count = o.count("count");
  const std::vector<std::size_t> scans = selection.indices(dataset.size());
  if (scans.empty()) {
    throw Error("--start " + std::to_string(selection.start) + " selects no scan (the dataset has " +
                std::to_string(dataset.size()) + ")");
  }
  if (params.motion.type == MotionModelType::kOdometry && !dataset.has_odometry()) {
    throw Error("dataset " + dataset.dir().string() +
                " has no odom.txt, which motion_model odometry needs (or use --motion_model constant_velocity or diffusion)");
  }
  // Empty scan files are caught before any work starts; scans whose points are all NaN or out of range can
  // only be found while reading them.
  for (std::size_t idx : scans) {
    std::error_code size_error;
    if (fs::file_size(dataset.scan_path(idx), size_error) == 0 && !size_error) {
      throw Error(dataset.scan_path(idx).string() + ": empty scan file");
    }
  }
  const TsdfMap map = load_map(map_file);
  EvaluatorOptions eo;
  eo.backend = parse_backend(o.text("backend"));
  eo.cpu_threads = static_cast<int>(o.count("cpu_threads"));
  std::string note;
  const std::unique_ptr<SensorEvaluator> evaluator = make_evaluator(map, eo, &note);
  std::fprintf(stderr, "localize: %s\n", note.c_str());

  std::error_code ec;
  fs::create_directories(out_dir, ec);
  if (ec) throw Error("cannot create output folder " + out_dir.string() + ": " + ec.message());

  ParticleFilter filter(map, *evaluator, params, scan_params.max_beams);
  const auto t_init = Clock::now();
  if (init_pose) {
    filter.initialize_local(*init_pose);
    std::fprintf(stderr, "localize: %zu particles around the initial pose\n", params.initial_particles);
  } else {
    filter.initialize_global();
    std::fprintf(stderr, "localize: %zu particles uniform over %zu free-space voxels\n", params.initial_particles,
                 filter.free_space_voxels());
  }
  const double init_ms = ms_since(t_init);
  const std::size_t snapshot_every = o.count("snapshot_every");
  const fs::path snapshot_dir = out_dir / "snapshots";
  if (snapshot_every > 0) {
    fs::create_directories(snapshot_dir, ec);
    if (ec) throw Error("cannot create " + snapshot_dir.string() + ": " + ec.message());
    write_snapshot(filter, snapshot_dir / "init.bin");
  }

  ScanPreprocessor preprocessor(scan_params);
  std::vector<StampedPose> trajectory;
  nlohmann::json per_scan = nlohmann::json::array();
  std::size_t updates = 0, dropped_total = 0, min_count = filter.particle_count(), max_count = filter.particle_count();
  std::vector<double> update_ms;
  constexpr std::size_t kNever = static_cast<std::size_t>(-1);
  std::size_t converged_since = kNever;  // position in `scans` from which the filter stayed converged
  const auto t_run = Clock::now();
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const std::size_t idx = scans[k];
    auto t0 = Clock::now();
    std::size_t dropped = 0;
    const PointCloud cloud = dataset.load_scan(idx, &dropped);
    const double load_ms = ms_since(t0);
    dropped_total += dropped;
    if (cloud.empty()) {
      throw Error(dataset.scan_path(idx).string() + ": no finite points" +
                  (dropped > 0 ? " (" + std::to_string(dropped) + " NaN/Inf points dropped)" : std::string()));
    }
    t0 = Clock::now();
    PreprocessingStats stats;
    const std::vector<Eigen::Vector3f>& points = preprocessor.process(cloud.points, idx, &stats);
    const double preprocess_ms = ms_since(t0);
    if (points.empty()) {
      char buf[160];
      std::snprintf(buf, sizeof(buf), ": none of %zu points lies within laser_min_range %.2f m .. laser_max_range %.2f m",
                    cloud.size(), static_cast<double>(scan_params.laser_min_range),
                    static_cast<double>(scan_params.laser_max_range));
      throw Error(dataset.scan_path(idx).string() + buf);
    }
    const std::optional<Pose> odometry = dataset.has_odometry() ? std::optional<Pose>(dataset.odometry(idx)) : std::nullopt;
    const std::size_t before = filter.particle_count();
    const FilterStep step = filter.update(dataset.time(idx), points, odometry);
    trajectory.push_back({dataset.time(idx), step.estimate.pose});
    if (step.updated) {
      ++updates;
      update_ms.push_back(step.timings.total_ms);
      min_count = std::min(min_count, step.next_particles);
      max_count = std::max(max_count, step.next_particles);
      if (!step.estimate.converged) converged_since = kNever;
      else if (converged_since == kNever) converged_since = k;
    }

    nlohmann::json j;
    j["scan"] = idx;
    j["time"] = dataset.time(idx);
    j["updated"] = step.updated;
    j["points"] = {{"raw", cloud.size() + dropped}, {"dropped_non_finite", dropped}, {"in_range", stats.in_range},
                   {"thinned", stats.thinned}, {"used", stats.output}};
    j["timings_ms"] = {{"load", load_ms}, {"preprocess", preprocess_ms}};
    if (step.updated) {
      const StepTimings& t = step.timings;
      j["particles"] = step.particles;
      j["particles_after"] = step.next_particles;
      j["resampled"] = step.resampled;
      j["kld_bins"] = step.kld_bins;
      j["injected"] = step.injected;
      j["ess"] = step.ess;
      j["tempering"] = step.tempering;
      j["fit"] = step.fit;
      j["w_slow"] = step.w_slow;
      j["w_fast"] = step.w_fast;
      j["timings_ms"].update({{"motion", t.motion_ms},
                              {"upload", t.upload_ms},
                              {"weight", t.weight_ms},
                              {"weight_gpu", number_or_null(t.weight_gpu_ms)},
                              {"reduce_gpu", number_or_null(t.reduce_gpu_ms)},
                              {"reduce_host", t.reduce_ms},
                              {"resample", t.resample_ms},
                              {"update_total", t.total_ms}});
    } else {
      j["particles"] = before;
    }
    j["estimate"] = pose_json(step.estimate.pose);
    j["converged"] = step.estimate.converged;
    j["mode_weight"] = step.estimate.mode_weight;
    j["modes"] = step.estimate.modes;
    j["std_position_m"] = step.estimate.std_position;
    j["std_rotation_deg"] = step.estimate.std_rotation * kDeg;
    if (snapshot_every > 0 && k % snapshot_every == 0) {
      char name[32];
      std::snprintf(name, sizeof(name), "scan_%06zu.bin", idx);
      write_snapshot(filter, snapshot_dir / name);
      j["snapshot"] = (snapshot_dir / name).string();
    }
    per_scan.push_back(std::move(j));

    if (step.updated) {
      std::fprintf(stderr, "[%zu/%zu] scan %zu: %zu points, particles %zu -> %zu, update %.1f ms, %s%s\n", k + 1,
                   scans.size(), idx, points.size(), step.particles, step.next_particles, step.timings.total_ms,
                   step.estimate.converged ? "converged" : "not converged",
                   step.injected > 0 ? (", " + std::to_string(step.injected) + " random particles").c_str() : "");
    } else {
      std::fprintf(stderr, "[%zu/%zu] scan %zu: held by the motion gate (update_min_d / update_min_a), %zu particles, %s\n",
                   k + 1, scans.size(), idx, before, step.estimate.converged ? "converged" : "not converged");
    }
    if (dropped > 0) std::fprintf(stderr, "  scan %zu: dropped %zu NaN/Inf points\n", idx, dropped);
  }
  const double run_s = ms_since(t_run) / 1000.0;

  write_tum(out_dir / "trajectory.tum", trajectory);
  std::vector<double> sorted = update_ms;
  std::sort(sorted.begin(), sorted.end());
  nlohmann::json report;
  report["command"] = "localize";
  report["backend"] = evaluator->backend();
  report["device"] = evaluator->device_name();
  report["backend_note"] = note;
  report["map"] = {{"file", map_file},
                   {"voxel_size", map.voxel_size()},
                   {"truncation", map.truncation()},
                   {"free_space_voxels", init_pose ? nlohmann::json(nullptr) : nlohmann::json(filter.free_space_voxels())}};
  report["dataset"] = {{"dir", dataset.dir().string()}, {"scans", dataset.size()}, {"selected", scans.size()}};
  report["parameters"] = parameters_json(o);
  report["initialization"] = {{"mode", init_pose ? "local" : "global"}, {"particles", params.initial_particles}, {"ms", init_ms}};
  report["summary"] = {
      {"scans", scans.size()},
      {"filter_updates", updates},
      {"dropped_non_finite_points", dropped_total},
      {"final_converged", filter.estimate().converged},
      {"converged_since_scan", converged_since != kNever ? nlohmann::json(scans[converged_since]) : nlohmann::json(nullptr)},
      {"converged_since_s", converged_since != kNever
                                ? nlohmann::json(dataset.time(scans[converged_since]) - dataset.time(scans.front()))
                                : nlohmann::json(nullptr)},
      {"particles", {{"initial", params.initial_particles}, {"min", min_count}, {"max", max_count}, {"final", filter.particle_count()}}},
      {"update_ms", {{"mean", update_ms.empty() ? 0.0 : std::accumulate(update_ms.begin(), update_ms.end(), 0.0) / static_cast<double>(update_ms.size())},
                     {"median", sorted.empty() ? 0.0 : sorted[sorted.size() / 2]},
                     {"max", sorted.empty() ? 0.0 : sorted.back()}}},
      {"wall_s", run_s},
  };
  report["scans"] = std::move(per_scan);
  const fs::path report_file = out_dir / "report.json";
  std::ofstream out(report_file);
  out << report.dump(1) << "\n";
  if (!out) throw Error("cannot write " + report_file.string());
  const nlohmann::json& summary = report["summary"];
  std::fprintf(stderr,
               "localize: %zu scans, %zu filter updates in %.1f s (update mean %.1f ms, median %.1f ms); particles %zu "
               "initial, %zu..%zu, %zu final; %s; wrote %s and %s\n",
               scans.size(), updates, run_s, summary["update_ms"]["mean"].get<double>(),
               summary["update_ms"]["median"].get<double>(), params.initial_particles, min_count, max_count,
               filter.particle_count(), filter.estimate().converged ? "converged" : "NOT converged",
               (out_dir / "trajectory.tum").c_str(), report_file.c_str());
  return 0;
}

}  // namespace tsdf_mcl::cli
