#include "tsdf_mcl/filter/convergence.hpp"

#include <cmath>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {

bool ConvergenceOptions::same_place(const Pose& a, const Pose& b) const {
  return (a.translation() - b.translation()).norm() <= max_jump_m &&
         rotation_angle_between(a.linear(), b.linear()) <= max_jump_rad;
}

void ConvergenceOptions::validate() const {
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0)) throw Error("converged_min_inliers must lie in [0, 1]");
  if (!(min_coverage >= 0.0 && min_coverage <= 1.0)) throw Error("converged_min_coverage must lie in [0, 1]");
  if (min_updates == 0) throw Error("converged_min_updates must be at least 1");
  if (!(max_jump_m > 0.0) || !std::isfinite(max_jump_m)) throw Error("convergence: max_jump_m must be positive");
  if (!(max_jump_rad > 0.0) || !std::isfinite(max_jump_rad)) throw Error("convergence: max_jump_rad must be positive");
  if (!(competitor_margin >= 0.0 && competitor_margin <= 1.0))
    throw Error("converged_competitor_margin must lie in [0, 1]");
  if (!(competitor_min_weight > 0.0 && competitor_min_weight <= 1.0))
    throw Error("converged_competitor_weight must lie in (0, 1]");
  if (!(travel_after_jump_m >= 0.0) || !std::isfinite(travel_after_jump_m)) {
    throw Error("converged_travel_after_jump must not be negative");
  }
}

ConvergenceMonitor::ConvergenceMonitor(const ConvergenceOptions& options) : options_(options) { options_.validate(); }

void ConvergenceMonitor::reset() {
  streak_ = 0;
  last_ = Pose::Identity();
  converged_once_ = false;
  concentrated_before_ = false;
  jumped_ = false;
  travel_ = 0.0;
}

void ConvergenceMonitor::restart_after_wrong_lock() {
  reset();
  jumped_ = true;
}

bool ConvergenceMonitor::challenged(const PoseEstimate& e) const {
  if (e.hypotheses.empty()) return false;
  const Hypothesis& top = e.hypotheses.front();
  for (std::size_t k = 1; k < e.hypotheses.size(); ++k) {
    const Hypothesis& h = e.hypotheses[k];
    const bool elsewhere = !options_.same_place(h.pose, top.pose);
    if (elsewhere && h.weight >= options_.competitor_min_weight &&
        explained_share(h) >= explained_share(top) - options_.competitor_margin) {
      return true;
    }
  }
  return false;
}

bool ConvergenceMonitor::update(const PoseEstimate& e, bool concentrated, const Pose& motion, bool lost, bool searched,
                                bool look_alike) {
  // A NaN coverage (not computed) does not hold convergence back.
  const bool plausible = e.inlier_ratio >= options_.min_inlier_ratio && !(e.coverage < options_.min_coverage);
  const Pose predicted = last_ * motion;
  const bool same_place = options_.same_place(predicted, e.pose);
  // A change of mind: the dominant hypothesis left a place the filter had converged at, or had concentrated on
  // (an operator's initial pose, a lock the background search then outscored).
  if ((converged_once_ || concentrated_before_) && !same_place) {
    jumped_ = true;
    travel_ = 0.0;
  }
  concentrated_before_ = concentrated;
  if (!(concentrated && plausible && searched) || look_alike || challenged(e)) {
    streak_ = 0;
  } else {
    if (!(streak_ > 0 && same_place)) travel_ = 0.0;
    streak_ = streak_ > 0 && same_place ? streak_ + 1 : 1;
  }
  travel_ += motion.translation().norm();
  last_ = e.pose;
  const bool proven = !jumped_ || travel_ >= options_.travel_after_jump_m;
  const bool converged = streak_ >= options_.min_updates && proven && !lost;
  if (converged) {
    converged_once_ = true;
    jumped_ = false;
  }
  return converged;
}

}  // namespace tsdf_mcl
