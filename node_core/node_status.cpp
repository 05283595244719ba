// What the core publishes after a scan: the pose, the particles and hypotheses, and /diagnostics (the filter's state
// and its reason, timings, or the problem that kept the scan from the filter; rejected messages).
#include <cmath>
#include <cstdio>
#include <string>

#include "localization_core.hpp"
#include "status_content.hpp"
#include "tsdf_mcl/core/one_line.hpp"

namespace tsdf_mcl::node {
namespace {

const char* const kStatusName = "tsdf_mcl: localization";

std::string number(double v) { return std::to_string(v); }

}  // namespace

void LocalizationCore::publish(Stamp stamp, const ScanRecord& record, double update_ms) {
  const PoseEstimate& e = record.step.estimate;
  PoseOut pose;
  pose.stamp = stamp;
  pose.frame_id = settings_.global_frame_id;
  pose.pose = e.pose;
  pose.covariance = fixed_frame_covariance(e.pose, e.covariance);
  out_.publish_pose(pose);

  PosesOut hypotheses;
  hypotheses.stamp = stamp;
  hypotheses.frame_id = settings_.global_frame_id;
  for (const Place& h : e.places) {
    hypotheses.poses.push_back(h.pose);
    hypotheses.weights.push_back(h.weight);
  }
  out_.publish_hypotheses(hypotheses);

  if (record.step.updated && settings_.max_published_particles > 0 && out_.particles_wanted()) {
    out_.publish_particles(decimated_particles(localizer_->snapshot(),
                                               static_cast<std::size_t>(settings_.max_published_particles), stamp,
                                               settings_.global_frame_id));
  }
  publish_status(stamp, record, update_ms);
}

void LocalizationCore::add_rejections(DiagnosticOut& status) {
  std::lock_guard<std::mutex> lock(mutex_);
  status.values.emplace_back("skipped_scans", std::to_string(skipped_));
  status.values.emplace_back("rejected_messages", std::to_string(rejected_));
  status.values.emplace_back("last_rejection", last_rejection_);
  status.values.emplace_back("time_jumps", std::to_string(time_jumps_));
}

void LocalizationCore::add_requests(DiagnosticOut& status) const {
  status.values.emplace_back("initial_poses", std::to_string(counters_.initial_poses));
  status.values.emplace_back("global_searches", std::to_string(counters_.global_searches));
}

void LocalizationCore::publish_problem(Stamp stamp, const std::string& problem) {
  char head[64];
  std::snprintf(head, sizeof(head), "tsdf_mcl: scan at %.3f not used: ", stamp.seconds());
  log_throttled("problem", 5.0, LogLevel::kWarn, head + problem);
  DiagnosticOut status;
  status.stamp = stamp;
  status.name = kStatusName;
  status.hardware_id = settings_.base_frame_id;
  status.level = DiagnosticOut::kError;
  status.message = one_line(problem);
  status.values = {{"state", "no scan used"},
                   {"reason", status.message},
                   {"problem", status.message},
                   {"processed_scans", std::to_string(counters_.processed)},
                   {"failed_scans", std::to_string(counters_.failed)}};
  add_rejections(status);
  add_requests(status);
  out_.publish_diagnostics(status);
}

void LocalizationCore::publish_status(Stamp stamp, const ScanRecord& record, double update_ms) {
  const PoseEstimate& e = record.step.estimate;
  const std::string state = to_string(record.step.state);
  DiagnosticOut status;
  status.stamp = stamp;
  status.name = kStatusName;
  status.hardware_id = settings_.base_frame_id;
  // The library classifies (track_state.hpp); the node only reports it, with the numbers that say why.
  status.level = state == "converged" ? DiagnosticOut::kOk
                 : state == "lost"    ? DiagnosticOut::kError
                                      : DiagnosticOut::kWarn;
  status.message = state;
  status.values = {{"state", state},
                   {"reason", state_reason(record.step)},
                   {"hypotheses", places_text(e.places)},
                   {"update_ms", number(update_ms)},
                   {"scan_period_ms", number(1000.0 * scan_period_)},
                   {"processed_scans", std::to_string(counters_.processed)},
                   {"late_updates", std::to_string(counters_.late)},
                   {"failed_scans", std::to_string(counters_.failed)}};
  add_rejections(status);
  add_requests(status);
  status.values.emplace_back("particles", std::to_string(record.step.particles));
  status.values.emplace_back("inlier_ratio", number(e.inlier_ratio));
  status.values.emplace_back("map_coverage", number(e.coverage));
  // Places the ledger has not told from the track (place_ledger.hpp): while any is listed, `converged` is not entered
  // (a converged track keeps it until a rival is proven better).
  status.values.emplace_back("rivals", positions_text(record.step.rivals));
  status.values.emplace_back("extrinsic", last_extrinsic_source_);  // tf, or the sensor_extrinsics parameter
  status.values.emplace_back("backend", localizer_->evaluator().backend());
  out_.publish_diagnostics(status);
}

}  // namespace tsdf_mcl::node
