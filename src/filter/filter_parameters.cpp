#include "tsdf_mcl/filter/filter_parameters.hpp"

#include <cmath>
#include <string>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/recovery.hpp"

namespace tsdf_mcl {
namespace {

void check_non_negative(double value, const char* name) {
  if (!(value >= 0.0) || !std::isfinite(value)) throw Error(std::string(name) + " must not be negative");
}

void check_share(double value, const char* name) {
  if (!(value >= 0.0 && value <= 1.0)) throw Error(std::string(name) + " must lie in [0, 1]");
}

}  // namespace

void GlobalSearchOptions::validate() const {
  if (screen_points == 0) throw Error("init_screen_points must be at least 1");
  if (!(screen_sigma > 0.0f) || !std::isfinite(screen_sigma)) throw Error("init_screen_sigma must be positive");
  proposal.validate();
}

void RecoveryOptions::validate() const {
  check_share(min_inliers, "recovery_min_inliers");
  check_non_negative(challenger_interval, "challenger_interval");
}

void PlaceOptions::validate() const {
  check_non_negative(evidence_points, "hypothesis_evidence_points");
  if (!(min_weight > 0.0 && min_weight <= 1.0)) throw Error("places: min_weight must lie in (0, 1]");
  if (!(credible_weight > 0.0 && credible_weight <= 1.0)) throw Error("places: credible_weight must lie in (0, 1]");
  if (!(inlier_distance > 0.0f) || !std::isfinite(inlier_distance)) throw Error("inlier_distance must be positive");
  if (!(switch_ratio >= 1.0) || !std::isfinite(switch_ratio)) throw Error("estimate_switch_ratio must be at least 1");
  check_share(decisive_inlier_gap, "decisive_inlier_gap");
  check_non_negative(see_through_weight, "see_through_weight");
  check_non_negative(wall_tilt_information, "wall_tilt_information");
  check_share(most_of_the_scan, "places: most_of_the_scan");
  check_share(nearly_all_of_the_scan, "places: nearly_all_of_the_scan");
  check_share(frontier_min_inliers, "places: frontier_min_inliers");
  check_share(frontier_coverage_gap, "places: frontier_coverage_gap");
  check_share(refine_again_gap, "places: refine_again_gap");
  if (!(track_radius > 0.0) || !std::isfinite(track_radius)) throw Error("places: track_radius must be positive");
}

void FilterParameters::validate() const {
  if (initial_particles == 0) throw Error("--particles must be at least 1");
  kld.validate();
  if (resample_interval == 0) throw Error("resample_interval must be at least 1");
  check_share(resample_ess_ratio, "resample_ess_ratio");
  if (!(min_ess_ratio >= 0.0 && min_ess_ratio < 1.0)) throw Error("min_ess_ratio must lie in [0, 1)");
  subset_first.validate();
  sensor.validate();
  motion.validate();
  check_non_negative(update_min_d, "update_min_d");
  check_non_negative(update_min_a, "update_min_a");
  check_non_negative(roughening.xyz, "roughening_xyz");
  check_non_negative(roughening.angle, "roughening_angle");
  check_non_negative(roughening.interval, "roughening_interval");
  RecoveryMonitor{recovery.alpha_slow, recovery.alpha_fast, recovery.margin};  // throws for bad alphas
  recovery.validate();
  places.validate();
  same_place.validate();
  ledger.validate();
  states.validate();
  global_init.validate();
  global_search.validate();
  local_init.validate();
  estimate.validate();
}

}  // namespace tsdf_mcl
