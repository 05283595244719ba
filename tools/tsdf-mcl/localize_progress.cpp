#include "localize_progress.hpp"

#include <cmath>
#include <cstdarg>
#include <cstdio>

#include "tsdf_mcl/localizer/last_pose_file.hpp"

namespace tsdf_mcl::cli {
namespace {

std::string format(const char* fmt, ...) __attribute__((format(printf, 1, 2)));
std::string format(const char* fmt, ...) {
  char buf[512];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buf, sizeof(buf), fmt, args);
  va_end(args);
  return buf;
}

}  // namespace

LocalizeNarrator::LocalizeNarrator(Progress& progress, const LocalizerOptions& options, std::size_t total_scans)
    : progress_(progress), options_(options), total_(total_scans) {}

// After the first update from an initial pose: the filter's own test of the fit (last_pose_file.hpp).
void LocalizeNarrator::explain_initial_fit(std::size_t index, const FilterStep& step) {
  explained_fit_ = true;
  const std::string misfit = initial_pose_misfit(step, options_, *options_.initial_pose);
  if (!misfit.empty()) {
    progress_.note(
        format("scan %zu does not fit at the given initial pose: %s; the filter is searching around it "
               "and, if the fit stays poor, the whole map",
               index, misfit.c_str()));
  }
}

void LocalizeNarrator::detail_line(std::size_t k, std::size_t index, const ScanRecord& record, std::size_t dropped) {
  const FilterStep& step = record.step;
  const char* state = to_string(step.state);
  if (step.updated) {
    progress_.detail(
        format("[%zu/%zu] scan %zu: %zu points, particles %zu -> %zu, update %.1f ms, %s, map coverage %.2f%s", k + 1,
               total_, index, record.points.output, step.particles, step.next_particles, step.timings.total_ms, state,
               step.estimate.coverage,
               step.injected > 0 ? (", " + std::to_string(step.injected) + " random particles").c_str() : ""));
  } else {
    progress_.detail(
        format("[%zu/%zu] scan %zu: held by the motion gate (update_min_d / update_min_a), %zu "
               "particles, %s",
               k + 1, total_, index, record.particles_before, state));
  }
  if (dropped > 0) progress_.detail(format("  scan %zu: dropped %zu NaN/Inf points", index, dropped));
}

void LocalizeNarrator::scan(std::size_t k, std::size_t index, const ScanRecord& record, std::size_t dropped) {
  const FilterStep& step = record.step;
  detail_line(k, index, record, dropped);
  if (dropped > 0 && dropped_scans_++ == 0 && !progress_.verbose()) {
    progress_.note(format("scan %zu: dropped %zu NaN/Inf points (later scans: report.json's points.dropped_non_finite)",
                          index, dropped));
  }
  bool milestone = false;
  if (step.updated) {
    if (options_.initial_pose && !explained_fit_) explain_initial_fit(index, step);
    if (step.injected > 0 && !searching_noted_ && reported_ != TrackState::kConverged) {
      searching_noted_ = true;
      progress_.note(
          format("scan %zu: the scan fits the belief poorly; the filter is searching the map with "
                 "random particles (recovery)",
                 index));
    }
    // The filter's state machine holds its states with hysteresis: every change is news, with its reason.
    if (step.state != reported_) {
      milestone = true;
      reported_ = step.state;
      if (reported_ == TrackState::kConverged && !first_converged_) first_converged_ = index;
      if (reported_ != TrackState::kConverged) searching_noted_ = false;
    }
  }
  std::string status = std::to_string(step.updated ? step.next_particles : record.particles_before) + " particles, " +
                       to_string(reported_);
  if (milestone) {
    status = "scan " + std::to_string(index) + ": " + to_string(reported_) + " (" + to_string(step.reason) + "), " +
             status.substr(0, status.find(','));
  }
  progress_.update(k + 1, total_, status, milestone);
}

std::string LocalizeNarrator::verdict(const RunSummary& summary, std::optional<std::size_t> since_scan) const {
  if (summary.converged && since_scan) {
    return "converged (the filter's own flag) since scan " + std::to_string(*since_scan);
  }
  if (summary.converged) return "converged (the filter's own flag) at the end";
  if (!first_converged_) return "NOT converged: the filter never claimed convergence";
  return "NOT converged at the end (the filter first claimed convergence at scan " + std::to_string(*first_converged_) +
         ")";
}

}  // namespace tsdf_mcl::cli
