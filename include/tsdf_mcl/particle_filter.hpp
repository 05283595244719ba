#pragma once
// The 6-DoF particle filter: motion update on the host, sensor update by a SensorEvaluator (GPU or CPU),
// resampling with KLD-adapted particle counts and recovery by random particles, all on the evaluator's
// particle buffers in place.
//
// One update():
//   motion gate (update_min_d / update_min_a on the motion since the last filter update; also a time
//   interval until the first convergence) -> motion update (+ roughening until the first convergence) -> sensor update (evaluator) -> tempering -> recovery's fit averages
//   -> pose estimate of the dominant mode -> resampling when due.
// Scans the gate holds back move only the estimate (by the motion since the last update), not the particles:
// noise that grows with the motion must be drawn once for the whole motion, not once per small step.
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "tsdf_mcl/endpoint_model.hpp"
#include "tsdf_mcl/kld_sampling.hpp"
#include "tsdf_mcl/motion_model.hpp"
#include "tsdf_mcl/particle_init.hpp"
#include "tsdf_mcl/pose_estimate.hpp"
#include "tsdf_mcl/recovery.hpp"
#include "tsdf_mcl/resampling.hpp"
#include "tsdf_mcl/sensor_evaluator.hpp"

namespace tsdf_mcl {

// The endpoint model with the filter's default tempering, weight_exponent 0.2. Neighbouring beams and
// successive scans see the same surfaces with the same map errors, so the untempered product of 500 points per
// scan, one scan per 0.1 m, collapses a global belief within a metre of travel onto whichever of two look-alike
// rooms a particle happened to fit best. Measured on the simulated office's 10 test routes: 9 converge with
// 0.2, 8 with 1 (docs/filter.md).
inline EndpointModel filter_sensor_model() {
  EndpointModel m;
  m.weight_exponent = 0.2f;
  return m;
}

struct FilterParameters {
  std::size_t initial_particles = 100000;  // particles of a global or local initialization
  KldParameters kld;                      // min_particles, max_particles, pf_err, pf_z, bins
  ResamplingMethod resample_method = ResamplingMethod::kSystematic;
  // Resampling is considered every resample_interval-th update, and done when the effective sample size is
  // below resample_ess_ratio * particles, when recovery injects particles, or when KLD-sampling wants a
  // particle count outside [particles / 2, particles] (the count only changes by resampling).
  std::size_t resample_interval = 1;
  double resample_ess_ratio = 0.5;
  // Recovery (augmented MCL): round(share * max_particles) random particles join the next generation, with
  // share = 1 - w_fast / (w_slow (1 - recovery_margin)) clamped to [0, 1] (see recovery.hpp). Scaling by max_particles rather than by the current count makes the
  // response follow the evidence: a brief dip in fit adds a few random particles to a small converged set, a
  // lost track floods the map. The fit averaged is WeightSummary::fit_sum / n, except right after an
  // injection: then it is the same mean taken over the particles that descend from the belief only, because
  // the fresh random particles fit badly by nature, and counting them would keep the fit low and the
  // injection going after the track is found again. Both 0 = off.
  double recovery_alpha_slow = 0.02;
  double recovery_alpha_fast = 0.1;
  double recovery_margin = 0.3;
  // sigma_hit, z_hit, z_rand, max_range (= laser_max_range), weight_exponent (0.2: filter_sensor_model).
  EndpointModel sensor = filter_sensor_model();
  // Adaptive tempering: if the weights of an update would leave fewer than min_ess_ratio * particles
  // effective particles (particles injected by recovery in the last resampling not counted), its
  // log-likelihoods are scaled down until they do not. Keeps a peaky likelihood from collapsing the set onto a
  // few lucky particles. 0 = off.
  double min_ess_ratio = 0.1;
  MotionParameters motion;
  double update_min_d = 0.1;  // m
  double update_min_a = 0.1;  // rad
  // Until the filter first converges after an initialization, every update adds a random walk of these
  // standard deviations per axis on top of the motion noise, and a scan the motion gate would hold is still an
  // update once roughening_interval has passed since the last one. A global belief is sparse: its particles
  // nearest the true pose are typically decimetres and degrees off, where the likelihood of hundreds of points
  // cannot tell them from a wrong place. Roughening lets them climb the likelihood over a few scans before
  // selection judges them, also while the robot stands still. The interval keeps a fast sensor (20 Hz) from
  // judging the same view again and again, which locks onto a wrong place in a symmetric building.
  // 0 = off.
  double roughening_xyz = 0.1;       // m
  double roughening_angle = 0.04;    // rad
  double roughening_interval = 1.0;  // s
  GlobalInitOptions global_init;
  LocalInitSpread local_init;
  PoseEstimateOptions estimate;
  std::uint64_t seed = 0;

  void validate() const;  // throws Error naming the parameter
};

struct StepTimings {
  double motion_ms = 0.0;
  double upload_ms = 0.0;      // scan points into the evaluator
  double weight_ms = 0.0;      // evaluator: weighting + reduction, host wall time
  double weight_gpu_ms = 0.0;  // GPU timestamps (NaN without)
  double reduce_gpu_ms = 0.0;
  double reduce_ms = 0.0;      // host: tempering, normalization, recovery averages, pose estimate
  double resample_ms = 0.0;    // KLD count, resampling, injection
  double total_ms = 0.0;
};

struct FilterStep {
  bool updated = false;    // false: the motion gate held this scan back; only the estimate moved
  bool resampled = false;
  std::size_t particles = 0;       // particles weighted in this update
  std::size_t next_particles = 0;  // after resampling
  std::size_t kld_bins = 0;        // bins occupied by the weighted set (when resampled)
  std::size_t injected = 0;        // random particles from recovery
  std::size_t points = 0;
  double ess = 0.0;                // effective sample size after tempering
  double tempering = 1.0;          // the adaptive factor applied to the log-likelihoods
  double fit = 0.0;                // mean per-point geometric-mean likelihood over particles
  double w_slow = 0.0;
  double w_fast = 0.0;
  double random_share = 0.0;       // 1 - w_fast / w_slow, clamped
  StepTimings timings;
  PoseEstimate estimate;
};

class ParticleFilter {
 public:
  // Reserves the evaluator's buffers for max(initial, max) particles and `points_hint` points up front; the
  // map and the evaluator must outlive the filter.
  ParticleFilter(const TsdfMap& map, SensorEvaluator& evaluator, const FilterParameters& params,
                 std::size_t points_hint = 512);

  void initialize_global();
  void initialize_local(const Pose& world_T_sensor);

  // One scan: `points` in the sensor frame (preprocessed, non-empty, finite); `odometry` = odom_T_sensor
  // at the scan (required by the odometry motion model, ignored otherwise).
  FilterStep update(double time, const std::vector<Eigen::Vector3f>& points, const std::optional<Pose>& odometry);

  bool initialized() const { return initialized_; }
  std::size_t particle_count() const { return count_; }
  const PoseEstimate& estimate() const { return estimate_; }
  const FilterParameters& params() const { return params_; }
  // The active particle set (views stay valid until the next update or initialization).
  ParticleArrays particles() const { return evaluator_.particles(); }
  // The active particles' weights, normalized (uniform right after resampling).
  std::vector<double> particle_weights() const;
  // Number of free-space voxels global initialization and recovery sample from (builds the table).
  std::size_t free_space_voxels();

 private:
  const FreeSpaceSampler& sampler();
  void start(std::size_t count);
  void prepare_weights(std::size_t n, FilterStep& step);
  double belief_fit(std::size_t n, const WeightSummary& summary, std::size_t points) const;
  void resample(std::size_t n, std::size_t kept, std::size_t injected, FilterStep& step);

  const TsdfMap& map_;
  SensorEvaluator& evaluator_;
  FilterParameters params_;
  std::unique_ptr<FreeSpaceSampler> sampler_;
  KldSampler kld_;
  PoseEstimator estimator_;
  RecoveryMonitor recovery_;

  std::size_t capacity_ = 0;
  std::size_t points_capacity_ = 0;
  std::size_t count_ = 0;
  bool initialized_ = false;
  std::uint64_t step_ = 0;  // filter updates so far: part of every random stream's name
  std::size_t updates_since_resample_ = 0;
  std::size_t injected_begin_ = 0;  // particles [injected_begin_, injected_end_) came from recovery
  std::size_t injected_end_ = 0;
  bool ever_converged_ = false;  // since the last initialization

  std::vector<double> prior_log_weight_;  // carried between updates that do not resample
  std::vector<double> weights_;           // exp(log weight - max)
  std::vector<std::uint32_t> ancestors_;

  // Motion bookkeeping at the last filter update.
  bool has_update_ = false;
  double last_time_ = 0.0;
  std::optional<Pose> last_odometry_;
  Pose last_estimate_pose_ = Pose::Identity();
  // Constant-velocity model: the estimated motion between the last two updates and its duration.
  std::optional<Pose> velocity_delta_;
  double velocity_dt_ = 0.0;

  PoseEstimate estimate_;
};

}  // namespace tsdf_mcl
