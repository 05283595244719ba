#pragma once
// Localization metrics of an estimated trajectory against ground truth in the same (map) frame: no
// alignment, since a localizer's whole job is to be right in the map's frame.
#include <cstddef>
#include <vector>

#include "tsdf_mcl/dataset.hpp"

namespace tsdf_mcl {

struct MetricsOptions {
  double max_translation_error = 0.3;       // m: "localized" threshold
  double max_rotation_error = 0.08726646;   // rad (5°)
  double time_tolerance = 0.02;             // s: nearest ground-truth stamp accepted when none matches exactly
};

struct PoseError {
  double time = 0.0;             // estimate's timestamp
  std::size_t truth_index = 0;   // matched ground-truth line
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  // estimate - truth, world frame
  double translation_norm = 0.0;
  double rotation = 0.0;         // rad
  bool localized = false;        // within both thresholds
};

struct TrajectoryMetrics {
  std::vector<PoseError> errors;   // one per estimate, in its order
  bool converged = false;          // some estimate from which all later ones are localized
  std::size_t convergence_index = 0;      // first such estimate
  double convergence_time = 0.0;          // its time minus the first estimate's
  double localized_fraction = 0.0;        // over all estimates
  // Over the estimates from convergence on (0 if not converged).
  std::size_t converged_count = 0;
  double ate_rmse = 0.0;           // m
  double rotation_rmse = 0.0;      // rad
  double max_translation_error = 0.0;
  double max_rotation_error = 0.0;
};

// Matches every estimate to a ground-truth pose by timestamp: exact within 1e-6 s, else the nearest within
// options.time_tolerance, else Error naming the estimate's time.
TrajectoryMetrics evaluate_trajectory(const std::vector<StampedPose>& estimate, const std::vector<double>& truth_times,
                                      const std::vector<Pose>& truth_poses, const MetricsOptions& options = {});

}  // namespace tsdf_mcl
