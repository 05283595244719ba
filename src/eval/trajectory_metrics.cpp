#include "tsdf_mcl/eval/trajectory_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {

namespace {

// Episodes of being far off after having been localized, each counted once it has lasted lost_duration.
void count_lost_tracks(TrajectoryMetrics& m, const MetricsOptions& options) {
  bool found = false;
  std::size_t off_since = 0;
  bool off = false, counted = false;
  for (std::size_t i = 0; i < m.errors.size(); ++i) {
    const PoseError& pe = m.errors[i];
    found = found || pe.localized;
    if (!found || pe.translation_norm <= options.lost_translation) {
      off = false;
      continue;
    }
    if (!off) {
      off = true;
      counted = false;
      off_since = i;
    }
    if (!counted && pe.time - m.errors[off_since].time > options.lost_duration) {
      counted = true;
      if (m.lost_tracks++ == 0) {
        m.first_lost_index = off_since;
        m.first_lost_time = m.errors[off_since].time - m.errors.front().time;
      }
    }
  }
}

}  // namespace

std::optional<std::size_t> nearest_stamp(const std::vector<double>& times, double time, double tolerance) {
  const auto it = std::lower_bound(times.begin(), times.end(), time);
  std::size_t best = times.size();
  double gap = std::numeric_limits<double>::infinity();
  for (auto c : {it, it == times.begin() ? it : it - 1}) {
    if (c == times.end()) continue;
    const double g = std::abs(*c - time);
    if (g < gap) {
      gap = g;
      best = static_cast<std::size_t>(c - times.begin());
    }
  }
  if (best == times.size() || (gap > 1e-6 && gap > tolerance)) return std::nullopt;
  return best;
}

TrajectoryMetrics evaluate_trajectory(const std::vector<StampedPose>& estimate, const std::vector<double>& times,
                                      const std::vector<Pose>& poses, const MetricsOptions& options,
                                      const std::vector<bool>* claims) {
  if (times.size() != poses.size()) {
    throw Error("evaluate: " + std::to_string(times.size()) + " ground-truth times but " +
                std::to_string(poses.size()) + " poses");
  }
  if (estimate.empty()) throw Error("evaluate: the estimated trajectory is empty");
  if (times.empty()) throw Error("evaluate: no ground truth");
  if (!std::is_sorted(times.begin(), times.end())) throw Error("evaluate: ground-truth times are not sorted");
  if (claims && claims->size() != estimate.size()) {
    throw Error("evaluate: " + std::to_string(claims->size()) + " convergence flags for " +
                std::to_string(estimate.size()) + " estimates");
  }

  TrajectoryMetrics m;
  m.errors.reserve(estimate.size());
  for (const StampedPose& e : estimate) {
    const std::optional<std::size_t> match = nearest_stamp(times, e.time, options.time_tolerance);
    if (!match) {
      char buf[160];
      std::snprintf(buf, sizeof(buf), "evaluate: estimate at t=%.9f has no ground-truth pose within %.3f s", e.time,
                    options.time_tolerance);
      throw Error(buf);
    }
    const std::size_t best = *match;
    PoseError pe;
    pe.time = e.time;
    pe.truth_index = best;
    pe.translation = e.pose.translation() - poses[best].translation();
    pe.translation_norm = pe.translation.norm();
    pe.rotation = rotation_angle_between(e.pose.linear(), poses[best].linear());
    pe.localized = pe.translation_norm <= options.max_translation_error && pe.rotation <= options.max_rotation_error;
    m.errors.push_back(pe);
  }

  if (claims) {
    m.has_claims = true;
    for (std::size_t i = 0; i < m.errors.size(); ++i) {
      if (!(*claims)[i]) continue;
      const PoseError& pe = m.errors[i];
      if (m.claimed_converged++ == 0) {
        m.first_claim_index = i;
        m.first_claim_time = pe.time - m.errors.front().time;
      }
      if (pe.translation_norm <= options.false_convergence_translation &&
          pe.rotation <= options.false_convergence_rotation) {
        continue;
      }
      if (m.false_convergence++ == 0) {
        m.first_false_index = i;
        m.first_false_time = pe.time - m.errors.front().time;
      }
    }
  }

  count_lost_tracks(m, options);
  std::size_t localized = 0;
  for (const PoseError& pe : m.errors) localized += pe.localized ? 1 : 0;
  m.localized_fraction = static_cast<double>(localized) / static_cast<double>(m.errors.size());
  // The convergence point: right after the last estimate that is not localized.
  std::size_t k = m.errors.size();
  while (k > 0 && m.errors[k - 1].localized) --k;
  m.converged = k < m.errors.size();
  if (!m.converged) return m;
  m.convergence_index = k;
  m.convergence_time = m.errors[k].time - m.errors.front().time;
  double t2 = 0.0, r2 = 0.0;
  for (std::size_t i = k; i < m.errors.size(); ++i) {
    const PoseError& pe = m.errors[i];
    t2 += pe.translation_norm * pe.translation_norm;
    r2 += pe.rotation * pe.rotation;
    m.max_translation_error = std::max(m.max_translation_error, pe.translation_norm);
    m.max_rotation_error = std::max(m.max_rotation_error, pe.rotation);
  }
  m.converged_count = m.errors.size() - k;
  m.ate_rmse = std::sqrt(t2 / static_cast<double>(m.converged_count));
  m.rotation_rmse = std::sqrt(r2 / static_cast<double>(m.converged_count));
  return m;
}

double FlagStability::flagged_share() const {
  return right_scans > 0 ? static_cast<double>(right_flagged) / static_cast<double>(right_scans)
                         : std::numeric_limits<double>::quiet_NaN();
}

double FlagStability::changes_per_minute() const {
  return minutes > 0.0 ? static_cast<double>(flag_changes) / minutes : std::numeric_limits<double>::quiet_NaN();
}

FlagStability flag_stability(const TrajectoryMetrics& m, const std::vector<bool>& claims,
                             const std::vector<std::string>* states) {
  if (claims.size() != m.errors.size() || (states && states->size() != m.errors.size())) {
    throw Error("evaluate: one converged flag and state per estimate needed");
  }
  FlagStability f;
  if (m.claimed_converged == 0) return f;
  const std::size_t first = m.first_claim_index;
  f.minutes = (m.errors.back().time - m.errors[first].time) / 60.0;
  for (std::size_t i = first; i < m.errors.size(); ++i) {
    if (i > first && claims[i] != claims[i - 1]) ++f.flag_changes;
    if (!m.errors[i].localized) continue;
    ++f.right_scans;
    if (claims[i]) {
      ++f.right_flagged;
    } else if (states) {
      ++f.unflagged_right_states[(*states)[i]];
    }
    if (states && (*states)[i] == "lost") ++f.lost_while_right;
  }
  return f;
}

}  // namespace tsdf_mcl
