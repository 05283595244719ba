#include "tsdf_mcl/localizer/localization_report.hpp"

#include <cmath>
#include <string>

#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kDeg = 57.29577951308232;

// NaN (no GPU timestamps, a fit not computed) is not valid JSON.
nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

nlohmann::json pose_json(const Pose& p) {
  const Eigen::Quaterniond q(p.linear());
  const Eigen::Vector3d rpy = rpy_of(p.linear()) * kDeg;
  return {{"x", p.translation().x()},
          {"y", p.translation().y()},
          {"z", p.translation().z()},
          {"qw", q.w()},
          {"qx", q.x()},
          {"qy", q.y()},
          {"qz", q.z()},
          {"roll_deg", rpy.x()},
          {"pitch_deg", rpy.y()},
          {"yaw_deg", rpy.z()}};
}

nlohmann::json scan_json(const ScanRecord& r) {
  const FilterStep& step = r.step;
  const PoseEstimate& e = step.estimate;
  nlohmann::json j;
  j["time"] = r.time;
  j["updated"] = step.updated;
  j["points"] = {{"raw", r.points.input},
                 {"in_range", r.points.in_range},
                 {"thinned", r.points.thinned},
                 {"used", r.points.output}};
  j["timings_ms"] = {{"preprocess", r.preprocess_ms}};
  if (step.updated) {
    const StepTimings& t = step.timings;
    // The points a compact place's particles were weighed on among themselves (clear of unobserved space and its
    // frontier: docs/filter.md, "Which points are evidence"); null where every particle was weighed on all of them.
    j["points"]["track_evidence"] = step.weighed_points ? nlohmann::json(step.weighed_points) : nlohmann::json(nullptr);
    j["particles"] = step.particles;
    j["particles_after"] = step.next_particles;
    j["resampled"] = step.resampled;
    j["kld_bins"] = step.kld_bins;
    j["injected"] = step.injected;
    j["ess"] = step.ess;
    j["tempering"] = step.tempering;
    j["fit"] = step.fit;
    j["w_slow"] = step.w_slow;
    j["w_fast"] = step.w_fast;
    j["timings_ms"].update({{"motion", t.motion_ms},
                            {"upload", t.upload_ms},
                            {"weight", t.weight_ms},
                            {"weight_gpu", number_or_null(t.weight_gpu_ms)},
                            {"reduce_gpu", number_or_null(t.reduce_gpu_ms)},
                            {"walls", t.walls_ms},
                            {"own_points", t.own_points_ms},
                            {"tempering", t.tempering_ms},
                            {"places", t.places_ms},
                            {"ledger", t.ledger_ms},
                            {"decision", t.decision_ms},
                            {"resample", t.resample_ms},
                            {"update_total", t.total_ms}});
  } else {
    j["particles"] = r.particles_before;
  }
  j["estimate"] = pose_json(e.pose);
  j["converged"] = e.converged;
  j["place_weight"] = e.place_weight;
  j["place_count"] = e.place_count;
  j["std_position_m"] = e.std_position;
  j["std_rotation_deg"] = e.std_rotation * kDeg;
  j["inlier_ratio"] = number_or_null(e.inlier_ratio);
  j["see_through_ratio"] = number_or_null(e.see_through_ratio);
  j["coverage"] = number_or_null(e.coverage);
  j["state"] = to_string(step.state);
  j["reason"] = to_string(step.reason);
  if (step.updated) {
    j["holding"] = step.holding;
    if (step.holding) {
      j["challenge_evidence"] = step.challenge_evidence;
      j["challenge_travel_m"] = step.challenge_travel;
    }
    j["restored"] = step.restored;  // particles put back at a place the ledger favours
    // Places the ledger has not told from the track (place_ledger.hpp): while any is followed, `converged` waits.
    nlohmann::json rivals = nlohmann::json::array();
    for (const Pose& p : step.rivals) rivals.push_back(pose_json(p));
    j["rivals"] = std::move(rivals);
    j["concentrated"] = step.concentrated;
    j["implausible"] = step.implausible;
    nlohmann::json places = nlohmann::json::array();
    for (const Place& h : e.places) {
      places.push_back({{"weight", h.weight},
                        {"particles", h.particles},
                        {"pose", pose_json(h.pose)},
                        {"std_position_m", h.std_position},
                        {"std_rotation_deg", h.std_rotation * kDeg},
                        {"inlier_ratio", number_or_null(h.inlier_ratio)},
                        {"see_through_ratio", number_or_null(h.see_through_ratio)},
                        {"coverage", number_or_null(h.coverage)}});
    }
    j["places"] = std::move(places);
  }
  return j;
}

nlohmann::json initialization_json(const InitializationRecord& r) {
  nlohmann::json gravity = nullptr;
  if (r.global) {
    gravity = {{"source", r.gravity_source}, {"candidates", nlohmann::json::array()}};
    for (const GravityCandidate& c : r.candidates) {
      const auto or_null = [](bool has, float v) { return has ? nlohmann::json(v) : nlohmann::json(nullptr); };
      gravity["candidates"].push_back(
          {{"up", {c.up.x(), c.up.y(), c.up.z()}},
           {"angle_std_deg", c.angle_std * kDeg},
           {"support", c.support},
           {"height_m", or_null(c.has_height, c.height)},
           {"height_std_m", or_null(c.has_height, c.height_std)},
           {"height_from", c.has_height ? nlohmann::json(c.floor_patches > 0 ? "floor planes" : "lowest level")
                                        : nlohmann::json(nullptr)},
           {"ceiling_m", or_null(c.has_ceiling, c.ceiling)}});
    }
  }
  return {{"mode", r.global ? "global" : "local"},
          {"particles", r.particles},
          {"hypotheses_scored", r.hypotheses_scored},
          {"free_space_voxels", r.global ? nlohmann::json(r.free_space_voxels) : nlohmann::json(nullptr)},
          {"gravity", gravity},
          {"ms", r.ms}};
}

nlohmann::json summary_json(const RunSummary& s) {
  const auto optional = [](const auto& v) { return v ? nlohmann::json(*v) : nlohmann::json(nullptr); };
  nlohmann::json states = nlohmann::json::object();
  for (std::size_t k = 0; k < kTrackStates; ++k) states[to_string(static_cast<TrackState>(k))] = s.state_scans[k];
  return {{"scans", s.scans},
          {"filter_updates", s.updates},
          {"final_converged", s.converged},
          {"final_state", to_string(s.state)},
          {"scans_by_state", states},
          {"coverage_min", s.updates ? nlohmann::json(s.coverage_min) : nlohmann::json(nullptr)},
          {"converged_since_time", optional(s.converged_since_time)},
          {"converged_since_index", optional(s.converged_since_index)},
          {"particles", {{"min", s.particles_min}, {"max", s.particles_max}, {"final", s.particles_final}}},
          {"update_ms", {{"mean", s.update_ms_mean}, {"median", s.update_ms_median}, {"max", s.update_ms_max}}}};
}

ReportWriter::ReportWriter(std::filesystem::path entries_file)
    : entries_file_(std::move(entries_file)), out_(entries_file_) {
  if (!out_) throw Error("cannot write " + entries_file_.string());
}

void ReportWriter::add(const nlohmann::json& entry) { out_ << (count_++ ? ",\n" : "") << entry.dump(); }

void ReportWriter::write(const nlohmann::json& report, const std::filesystem::path& file) {
  out_.close();
  if (!out_) throw Error("cannot write " + entries_file_.string() + " (disk full?)");
  const std::string placeholder = "\"scans entries of " + entries_file_.string() + "\"";
  nlohmann::json with_placeholder = report;
  with_placeholder["scans"] = "scans entries of " + entries_file_.string();
  const std::string text = with_placeholder.dump(1) + "\n";
  const std::size_t at = text.find(placeholder);
  write_file_atomically(
      file,
      [&](const std::filesystem::path& temporary) {
        std::ofstream out(temporary, std::ios::binary);
        std::ifstream entries(entries_file_, std::ios::binary);
        out << text.substr(0, at) << "[\n";
        if (count_ > 0) out << entries.rdbuf();
        out << "\n]" << text.substr(at + placeholder.size());
        out.close();
        if (!out || !entries) throw Error("cannot write " + file.string() + " (disk full?)");
      },
      "report");
}

}  // namespace tsdf_mcl
