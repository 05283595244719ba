#pragma once
// Localization metrics of an estimated trajectory against ground truth in the same (map) frame: no
// alignment, since a localizer's whole job is to be right in the map's frame.
#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "tsdf_mcl/io/dataset.hpp"

namespace tsdf_mcl {

struct MetricsOptions {
  double max_translation_error = 0.3;      // m: "localized" threshold
  double max_rotation_error = 0.08726646;  // rad (5°)
  double time_tolerance = 0.02;            // s: nearest ground-truth stamp accepted when none matches exactly
  // A claim of convergence is false when the estimate is off by more than either of these.
  double false_convergence_translation = 1.0;      // m
  double false_convergence_rotation = 0.17453293;  // rad (10°)
  // A lost track: after an estimate was localized, the estimates stay more than lost_translation off for longer
  // than lost_duration (the robot was found and then thrown away, not merely not found yet).
  double lost_translation = 1.0;  // m
  double lost_duration = 2.0;     // s
};

struct PoseError {
  double time = 0.0;                                      // estimate's timestamp
  std::size_t truth_index = 0;                            // matched ground-truth line
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  // estimate - truth, world frame
  double translation_norm = 0.0;
  double rotation = 0.0;   // rad
  bool localized = false;  // within both thresholds
};

struct TrajectoryMetrics {
  std::vector<PoseError> errors;  // one per estimate, in its order
  // "Localized from estimate N": every estimate from N on is within the thresholds (the ground-truth test; the
  // filter's own `converged` flag is the claims below). Named converged for the metrics.json compatibility.
  bool converged = false;             // some estimate from which all later ones are localized
  std::size_t convergence_index = 0;  // first such estimate
  double convergence_time = 0.0;      // its time minus the first estimate's
  double localized_fraction = 0.0;    // over all estimates
  // Over the estimates from convergence on (0 if not converged).
  std::size_t converged_count = 0;
  double ate_rmse = 0.0;       // m
  double rotation_rmse = 0.0;  // rad
  double max_translation_error = 0.0;
  double max_rotation_error = 0.0;
  // Where the localizer's own `converged` flags are given: how often it said converged, and how often it said
  // so while wrong (false_convergence_* thresholds): the number a robot driving on the flag cares about.
  bool has_claims = false;
  std::size_t claimed_converged = 0;
  std::size_t false_convergence = 0;
  std::size_t first_claim_index = 0;  // estimate index of the first converged flag (if any)
  double first_claim_time = 0.0;      // its time minus the first estimate's
  std::size_t first_false_index = 0;  // estimate index of the first false claim (if any)
  double first_false_time = 0.0;      // its time minus the first estimate's
  // Lost tracks (MetricsOptions::lost_*): episodes, and the first estimate of the first one.
  std::size_t lost_tracks = 0;
  std::size_t first_lost_index = 0;
  double first_lost_time = 0.0;  // its time minus the first estimate's
};

// How steady the localizer's `converged` flag is once first raised: what a robot that gates on it sees. Counted over
// the estimates from the first claim on; "right" is evaluate's localized test (max_translation_error,
// max_rotation_error).
struct FlagStability {
  std::size_t right_scans = 0;       // right estimates from the first claim on
  std::size_t right_flagged = 0;     // of them, flagged converged
  std::size_t flag_changes = 0;      // changes of the flag after the first claim
  double minutes = 0.0;              // from the first claim to the last estimate
  std::size_t lost_while_right = 0;  // right estimates whose state is `lost`
  // The states of the right estimates that were not flagged converged (empty without states).
  std::map<std::string, std::size_t> unflagged_right_states;
  double flagged_share() const;       // right_flagged / right_scans (NaN without right scans)
  double changes_per_minute() const;  // flag_changes / minutes (NaN for a zero span)
};

// FlagStability of `m` (which must have claims: evaluate_trajectory with converged_claims); `states`, if given, one
// state name per estimate (report.json's `state`). Without a claim, all zero.
FlagStability flag_stability(const TrajectoryMetrics& m, const std::vector<bool>& claims,
                             const std::vector<std::string>* states = nullptr);

// The index of the stamp in `sorted_times` nearest to `time`, if it lies within `tolerance` (or within 1e-6 s: an
// exact match); nullopt otherwise. The one matcher of estimates to ground truth (evaluate, render).
std::optional<std::size_t> nearest_stamp(const std::vector<double>& sorted_times, double time, double tolerance);

// Matches every estimate to a ground-truth pose by timestamp: exact within 1e-6 s, else the nearest within
// options.time_tolerance, else Error naming the estimate's time.
// `converged_claims`, if given, holds one flag per estimate: the localizer's `converged`.
TrajectoryMetrics evaluate_trajectory(const std::vector<StampedPose>& estimate, const std::vector<double>& truth_times,
                                      const std::vector<Pose>& truth_poses, const MetricsOptions& options = {},
                                      const std::vector<bool>* converged_claims = nullptr);

}  // namespace tsdf_mcl
