#pragma once
// The 6-DoF particle filter: motion update on the host, sensor update by a SensorEvaluator (GPU or CPU), resampling
// with KLD-adapted particle counts and recovery, all on the evaluator's particle buffers in place; above it the places
// of the belief, the ledger that decides between them and the state machine a robot reads (docs/filter.md).
//
// One update(), its stages in order:
//   motion gate -> motion update (roughened until the first convergence) -> sensor update (evaluator)
//   -> places weighed on their own points -> tempering -> places: modes refined onto the map, their shares moved by
//   the evidence between them -> ledger: the track against its rivals -> state -> resampling (and what joins).
// Scans the gate holds back move only the estimate (by the motion since the last update), not the particles: noise
// that grows with the motion must be drawn once for the whole motion.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "tsdf_mcl/filter/filter_parameters.hpp"
#include "tsdf_mcl/filter/pose_estimate.hpp"
#include "tsdf_mcl/filter/scan_gravity.hpp"
#include "tsdf_mcl/filter/track_state.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

// What the global search may use of a scan besides the points of the sensor update.
struct ScanExtras {
  const std::vector<Eigen::Vector3f>* dense = nullptr;  // the scan before thinning (sensor frame)
  std::optional<Eigen::Vector3f> imu_up;                // gravity from an IMU: up in the sensor frame
};

// Host wall time of each stage of one update (ms); the stages do not overlap and add up to total_ms but for the
// bookkeeping between them.
struct StepTimings {
  double motion_ms = 0.0;      // motion gate and motion update
  double upload_ms = 0.0;      // scan points into the evaluator
  double weight_ms = 0.0;      // sensor update: weighting + reduction (the evaluator's wall time)
  double walls_ms = 0.0;       // the scan's planar patches, whose walls hold the refined tilt
  double own_points_ms = 0.0;  // places weighed on their own points (their evaluator passes included)
  double tempering_ms = 0.0;   // adaptive tempering
  double places_ms = 0.0;      // modes, each refined onto the map, the evidence between them and their shares
  double ledger_ms = 0.0;      // the track against its rivals
  double decision_ms = 0.0;    // recovery, the implausible-fit test, the state
  double resample_ms = 0.0;    // KLD count, resampling, what joins
  double total_ms = 0.0;
  double weight_gpu_ms = 0.0;  // GPU timestamps of the weighting (NaN without), included in weight_ms
  double reduce_gpu_ms = 0.0;
};

struct FilterStep {
  bool updated = false;  // false: the motion gate held this scan back; only the estimate moved
  bool resampled = false;
  std::size_t particles = 0;       // particles weighted in this update
  std::size_t next_particles = 0;  // after resampling
  std::size_t kld_bins = 0;        // bins occupied by the weighted set (when resampled)
  std::size_t injected = 0;        // particles from recovery
  std::size_t points = 0;
  std::size_t weighed_points = 0;  // of them, the first place weighed on its own points took these (0: all)
  double ess = 0.0;                // effective sample size after tempering
  double tempering = 1.0;          // the adaptive factor applied to the log-likelihoods
  double fit = 0.0;                // mean per-point geometric-mean likelihood over particles (diagnostic)
  double w_slow = 0.0;
  double w_fast = 0.0;
  double random_share = 0.0;    // share of the next generation from the proposal (recovery)
  bool concentrated = false;    // the dominant place holds converged_weight and is compact
  bool implausible = false;     // ... and its inlier ratio is below recovery_min_inliers
  std::vector<Pose> rivals;     // places the ledger has not told from the track (place_ledger.hpp)
  std::size_t challengers = 0;  // particles of the background search added in this update
  std::size_t restored = 0;     // particles put back at a place the ledger favours (the track, a proven rival)
  // The estimate holds the track against a dominant place elsewhere the ledger has not decided; its ratio for the
  // track so far (nats) and the travel it spans (m).
  bool holding = false;
  double challenge_evidence = 0.0;
  double challenge_travel = 0.0;
  TrackState state = TrackState::kSearching;  // what the filter can say about its track (track_state.hpp)
  StateReason reason = StateReason::kSpread;  // why
  bool state_changed = false;                 // the state differs from the last update's
  StepTimings timings;
  PoseEstimate estimate;
};

class ParticleFilter {
 public:
  // Reserves the evaluator's buffers for max(initial, max) particles and `points_hint` points up front; the map and
  // the evaluator must outlive the filter.
  ParticleFilter(const TsdfMap& map, SensorEvaluator& evaluator, const FilterParameters& params,
                 std::size_t points_hint = 512);
  ~ParticleFilter();
  ParticleFilter(const ParticleFilter&) = delete;
  ParticleFilter& operator=(const ParticleFilter&) = delete;

  // Uniform over the map's free space (within the tilt and height priors of global_init), no scan needed.
  void initialize_global();
  // Global search guided by the first scan (GlobalSearchOptions): `points` as for update(), `extras.dense` the same
  // scan before thinning, for its up direction and floor height.
  void initialize_global(const std::vector<Eigen::Vector3f>& points, const ScanExtras& extras);
  void initialize_local(const Pose& world_T_sensor);
  // ... with another spread than params().local_init (an initial pose given with its covariance).
  void initialize_local(const Pose& world_T_sensor, const LocalInitSpread& spread);

  // One scan: `points` in the sensor frame (preprocessed, non-empty, finite); `odometry` = odom_T_sensor at the scan
  // (required by the odometry motion model, ignored otherwise). `extras` guide recovery's hypotheses like a global
  // search's.
  FilterStep update(double time, const std::vector<Eigen::Vector3f>& points, const std::optional<Pose>& odometry,
                    const ScanExtras& extras = {});

  // The next update() weighs the scan even if the motion gate would hold it (nav2's request_nomotion_update).
  void request_update();

  bool initialized() const;
  std::size_t particle_count() const;
  const PoseEstimate& estimate() const;
  TrackState state() const;  // of the last scan
  const FilterParameters& params() const;
  // The active particle set (views stay valid until the next update or initialization).
  ParticleArrays particles() const;
  // The active particles' weights, normalized (uniform right after resampling).
  std::vector<double> particle_weights() const;
  // Number of free-space voxels global initialization and recovery sample from (builds the table).
  std::size_t free_space_voxels();
  // The gravity and height candidates of the last global search or recovery (empty: uniform).
  const std::vector<GravityCandidate>& gravity_candidates();

  class Core;  // the filter's state and stages (src/filter/filter_core.hpp)

 private:
  std::unique_ptr<Core> core_;
};

}  // namespace tsdf_mcl
