#pragma once
// The localization loop as a library object: a streaming facade over the particle filter for any frontend
// (the tsdf-mcl program over a dataset or a bag, a ROS node over live topics, a Python binding). It owns the
// sensor-update backend, the scan preprocessing, the filter, the IMU's gravity, the per-scan records and the run
// summary; frontends feed it scans, odometry and IMU samples as they arrive and read back the estimate, the
// hypotheses and the timings.
//
//   Localizer localizer(map, options);                      // builds the evaluator: Vulkan, else the CPU
//   for (each scan) {
//     const ScanRecord& r = localizer.process(time, points, odom_T_sensor);
//     use(r.step.estimate.pose, r.step.estimate.covariance, r.step.estimate.converged, r.step.estimate.places);
//   }
//   localizer.reset_to(pose);       // an operator's initial pose ("/initialpose")
//   localizer.reset_global();       // search the whole map again from the next scan ("global_localization")
#include <array>
#include <deque>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tsdf_mcl/io/imu.hpp"
#include "tsdf_mcl/filter/particle_filter.hpp"
#include "tsdf_mcl/io/particle_snapshot.hpp"
#include "tsdf_mcl/filter/scan_gravity.hpp"
#include "tsdf_mcl/filter/scan_preprocessing.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

struct LocalizerOptions {
  FilterParameters filter;
  ScanPreprocessing preprocessing;
  EvaluatorOptions evaluator;
  // Particles around this pose (FilterParameters::local_init) instead of a global search from the first scan.
  std::optional<Pose> initial_pose;
  // Gravity from add_imu() samples, where there are any near a scan's time, for the global search.
  bool use_imu = true;
};

// What one scan did.
struct ScanRecord {
  double time = 0.0;
  std::uint64_t index = 0;           // the scan's number in this run (0, 1, ...)
  PreprocessingStats points;         // input, in range, thinned, used
  std::size_t particles_before = 0;  // particles when the scan arrived
  double preprocess_ms = 0.0;
  FilterStep step;  // updated or held, the estimate with its places, timings, counts
};

// How the filter was started (the last initialization: global search or local).
struct InitializationRecord {
  bool global = true;
  std::size_t particles = 0;
  std::size_t hypotheses_scored = 0;
  std::string gravity_source;                // "scan", "imu" (global only)
  std::vector<GravityCandidate> candidates;  // the up directions and heights the search used
  std::size_t free_space_voxels = 0;
  double ms = 0.0;
};

struct RunSummary {
  std::size_t scans = 0;
  std::size_t updates = 0;
  bool converged = false;                     // the last estimate
  TrackState state = TrackState::kSearching;  // of the last scan
  // Scans per state (indexed by TrackState), every scan counted, held ones with the last update's state.
  std::array<std::size_t, kTrackStates> state_scans{};
  double coverage_min = 1.0;  // lowest map coverage of an update's estimate (track_state.hpp, scan_fit.hpp)
  std::optional<double> converged_since_time;  // time of the scan from which every update said converged
  std::optional<std::uint64_t> converged_since_index;
  std::size_t particles_min = 0, particles_max = 0, particles_final = 0;
  double update_ms_mean = 0.0, update_ms_max = 0.0;  // over every update
  double update_ms_median = 0.0;                     // over the latest 10,000
};

class Localizer {
 public:
  // Builds the sensor-update backend for `map` (options.evaluator; the map must outlive the localizer). Throws
  // Error for bad parameters (pose inputs beyond the map: map_extent_checks.hpp) or, with Backend::kVulkan, no
  // usable device.
  Localizer(const TsdfMap& map, const LocalizerOptions& options);
  ~Localizer();
  Localizer(const Localizer&) = delete;
  Localizer& operator=(const Localizer&) = delete;

  // An IMU sample (specific force in the LiDAR frame, the clock of the scans); kept for a few seconds.
  void add_imu(const ImuSample& sample);

  // One scan: `points` in the sensor frame as the sensor gave them (non-finite ones are not expected: frontends
  // drop them), `odometry` = odom_T_sensor at the scan (required by the odometry motion model). The first scan
  // starts the global search unless an initial pose was given. `scan_id` names the scan in the preprocessing's
  // random streams (default: its number in this run; a dataset's index makes a run over a subset of its scans
  // pick the same points as a run over all of them). Throws Error for a scan with no point left after the range
  // limits (the message names the limits), and for a stamp or odometry beyond the bounds of map_extent_checks.hpp
  // (the localizer is then left as it was). The record is valid until the next call.
  const ScanRecord& process(double time, const std::vector<Eigen::Vector3f>& points,
                            const std::optional<Pose>& odometry, std::optional<std::uint64_t> scan_id = std::nullopt);

  // Particles around `pose` now (local initialization), as an operator's "initial pose". Throws Error for a pose
  // outside the map or a spread larger than the map (map_extent_checks.hpp).
  void reset_to(const Pose& world_T_sensor);
  // ... spread by `spread` instead of the options' (an initial pose given with its covariance).
  void reset_to(const Pose& world_T_sensor, const LocalInitSpread& spread);
  // A global search from the next scan on, as after start-up without an initial pose.
  void reset_global();
  // The next scan is a filter update even if the platform has not moved (nav2's request_nomotion_update).
  void request_update() { filter_->request_update(); }

  const PoseEstimate& estimate() const { return filter_->estimate(); }
  // What the filter can say about its track after the last scan: searching, tracking, ambiguous, converged,
  // unmapped (tracking through space the map never observed) or lost.
  TrackState state() const { return filter_->state(); }
  // Map coverage at the estimate: the share of the last update's scan points with map evidence (NaN before one).
  double coverage() const { return filter_->estimate().coverage; }
  const ParticleFilter& filter() const { return *filter_; }
  const SensorEvaluator& evaluator() const { return *evaluator_; }
  const std::string& backend_note() const { return backend_note_; }
  const LocalizerOptions& options() const { return options_; }
  // The odometry of the last scan processed with odometry since the last initialization (process() checks the next
  // one's step against it).
  const std::optional<Pose>& last_odometry() const { return last_odometry_; }
  const std::optional<InitializationRecord>& initialization() const { return initialization_; }
  RunSummary summary() const;
  // The particle set with its normalized weights (tsdf-mcl render --particles draws it).
  ParticleSnapshot snapshot() const;

 private:
  void initialize(const std::vector<Eigen::Vector3f>* points, const ScanExtras& extras);

  const TsdfMap& map_;
  LocalizerOptions options_;
  std::string backend_note_;
  std::unique_ptr<SensorEvaluator> evaluator_;
  std::unique_ptr<ParticleFilter> filter_;
  ScanPreprocessor preprocessor_;
  std::deque<ImuSample> imu_;
  std::optional<InitializationRecord> initialization_;
  bool pending_global_ = true;
  std::optional<Pose> pending_pose_;
  std::optional<Pose> last_odometry_;  // see last_odometry()
  ScanRecord record_;
  // Summary bookkeeping.
  std::size_t scans_ = 0, updates_ = 0;
  std::size_t min_particles_ = 0, max_particles_ = 0;
  std::vector<double> update_ms_;  // the latest updates' times, for the median
  double update_ms_sum_ = 0.0, update_ms_max_ = 0.0;
  std::optional<double> converged_since_time_;
  std::optional<std::uint64_t> converged_since_index_;
  std::array<std::size_t, kTrackStates> state_scans_{};
  double coverage_min_ = 1.0;
};

}  // namespace tsdf_mcl
