#include <cmath>
#include <filesystem>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.hpp"
#include "dataset_source.hpp"
#include "options.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/render/image.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/core/one_line.hpp"
#include "tsdf_mcl/render/plot.hpp"
#include "tsdf_mcl/eval/trajectory_metrics.hpp"

namespace tsdf_mcl::cli {
namespace {

constexpr double kDeg = 57.29577951308232;

// Translation error per axis over time, as in the paper's figures; a second panel zooms in on the errors
// after convergence, which the initial error of a global localization would otherwise flatten.
LinePlot error_plot(const TrajectoryMetrics& m, std::size_t first, const std::string& title) {
  LinePlot plot;
  plot.title = title;
  plot.y_label = "error [m]";
  const Rgb colors[4] = {rgb_hex(0xd62728), rgb_hex(0x2ca02c), rgb_hex(0x1f77b4), rgb_hex(0x222222)};
  const char* labels[4] = {"x", "y", "z", "norm"};
  for (int a = 0; a < 4; ++a) {
    PlotSeries s;
    s.label = labels[a];
    s.color = colors[a];
    for (std::size_t i = first; i < m.errors.size(); ++i) {
      const PoseError& e = m.errors[i];
      s.x.push_back(e.time - m.errors.front().time);
      s.y.push_back(a < 3 ? e.translation[a] : e.translation_norm);
    }
    plot.series.push_back(std::move(s));
  }
  return plot;
}

void plot_errors(const TrajectoryMetrics& m, const MetricsOptions& mo, const std::string& file) {
  LinePlot all = error_plot(m, 0, "translation error per axis");
  char band[32];
  std::snprintf(band, sizeof(band), "%.2f m", mo.max_translation_error);
  all.horizontal_lines = {{mo.max_translation_error, std::string("+") + band},
                          {-mo.max_translation_error, std::string("-") + band}};
  if (!m.converged) {
    write_plot_png(all, file);
    return;
  }
  all.markers.emplace_back(m.convergence_time, "localized");
  const Image top = render_plot(all);
  const Image bottom = render_plot(error_plot(m, m.convergence_index, "from the scan localized on"));
  Image both(top.width(), top.height() + bottom.height());
  both.blit(top, 0, 0);
  both.blit(bottom, 0, top.height());
  save_png(both, file);
}

// The localizer's `converged` flag per estimate, from its report.json (localize writes one line per scan, in
// the trajectory's order and with the same times).
// `states`, if given, takes each scan's `state` ("" where the report has none).
std::vector<bool> converged_claims(const std::string& report_file, const std::vector<StampedPose>& estimate,
                                   std::vector<std::string>* states) {
  const std::string text = read_input_file(report_file, "report", limits::kMaxReportFileBytes);
  nlohmann::json report;
  try {
    report = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(report_file + ": not valid JSON (" + std::string(e.what()) + ")");
  }
  if (!report.is_object() || !report.contains("scans") || !report["scans"].is_array()) {
    throw Error(report_file + ": no \"scans\" list (not a localize report)");
  }
  const nlohmann::json& scans = report["scans"];
  if (scans.size() != estimate.size()) {
    throw Error(report_file + " describes " + std::to_string(scans.size()) + " scans but the trajectory has " +
                std::to_string(estimate.size()) + " poses (not the same run?)");
  }
  std::vector<bool> claims;
  claims.reserve(scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const nlohmann::json& s = scans[i];
    if (!s.is_object() || !s.contains("time") || !s["time"].is_number() || !s.contains("converged") ||
        !s["converged"].is_boolean()) {
      throw Error(report_file + ": scan entry " + std::to_string(i) + " lacks time or converged");
    }
    if (std::abs(s["time"].get<double>() - estimate[i].time) > 1e-6) {
      throw Error(report_file + ": scan entry " + std::to_string(i) +
                  " is not at the trajectory's time (not the same run?)");
    }
    claims.push_back(s["converged"].get<bool>());
    if (states) {
      const auto state = s.find("state");
      states->push_back(state != s.end() && state->is_string() ? state->get<std::string>() : std::string());
    }
  }
  return claims;
}

// The same in words, for a person watching (stdout is often redirected to a file). Two tests with two words:
// "localized from scan N" is evaluate's ground-truth test; "converged" is the filter's own flag from report.json.
void print_verdict(const TrajectoryMetrics& m, const MetricsOptions& mo, const std::string& report_file) {
  if (m.converged) {
    std::fprintf(stderr,
                 "evaluate: %zu scans; localized from scan %zu (%.1f s after the first; every estimate from there on "
                 "within %.2f m / %.0f deg of the truth); %.1f %% of scans localized; from there on ATE %.3f m, "
                 "rotation RMSE %.2f deg, worst %.3f m / %.2f deg\n",
                 m.errors.size(), m.errors[m.convergence_index].truth_index, m.convergence_time,
                 mo.max_translation_error, mo.max_rotation_error * kDeg, 100.0 * m.localized_fraction, m.ate_rmse,
                 m.rotation_rmse * kDeg, m.max_translation_error, m.max_rotation_error * kDeg);
  } else {
    std::fprintf(stderr,
                 "evaluate: %zu scans; NOT localized at the end (the last estimate is off by %.3f m / %.2f deg); "
                 "%.1f %% of scans localized\n",
                 m.errors.size(), m.errors.back().translation_norm, m.errors.back().rotation * kDeg,
                 100.0 * m.localized_fraction);
  }
  if (m.lost_tracks > 0) {
    const std::string times = m.lost_tracks == 1 ? "once" : std::to_string(m.lost_tracks) + " times";
    std::fprintf(stderr,
                 "evaluate: LOST TRACK: more than %.1f m off for over %.1f s after having been localized, %s (first "
                 "from scan %zu, %.1f s)\n",
                 mo.lost_translation, mo.lost_duration, times.c_str(), m.errors[m.first_lost_index].truth_index,
                 m.first_lost_time);
  }
  if (!m.has_claims) {
    std::fprintf(stderr, "evaluate: no report.json beside the estimate: the filter's converged flags not checked\n");
  } else if (m.claimed_converged == 0) {
    std::fprintf(stderr, "evaluate: the filter never claimed convergence (no scan flagged converged in %s)\n",
                 report_file.c_str());
  } else if (m.false_convergence > 0) {
    std::fprintf(stderr,
                 "evaluate: FALSE CONVERGENCE: the filter flagged converged at %zu of its %zu converged scans while "
                 "more than %.1f m or %.0f deg off (first at scan %zu, %.1f s)\n",
                 m.false_convergence, m.claimed_converged, mo.false_convergence_translation,
                 mo.false_convergence_rotation * kDeg, m.errors[m.first_false_index].truth_index, m.first_false_time);
  } else {
    std::fprintf(stderr,
                 "evaluate: the filter flagged converged at %zu scans (first at scan %zu), each within %.1f m and "
                 "%.0f deg of the truth: no false convergence\n",
                 m.claimed_converged, m.errors[m.first_claim_index].truth_index, mo.false_convergence_translation,
                 mo.false_convergence_rotation * kDeg);
  }
}

// The thresholds of evaluate's test and of a false converged flag, checked.
MetricsOptions metrics_options(const Options& o) {
  MetricsOptions mo;
  mo.max_translation_error = o.number("max_translation_error");
  mo.max_rotation_error = angle_in_degrees(o.text("max_rotation_error"), "--max_rotation_error", M_PI);
  mo.time_tolerance = o.number("time_tolerance");
  if (!(mo.max_translation_error > 0.0) || !(mo.max_rotation_error > 0.0) || !(mo.time_tolerance >= 0.0)) {
    throw Error("thresholds must be positive and the time tolerance non-negative");
  }
  mo.false_convergence_translation = o.number("false_convergence_translation");
  mo.false_convergence_rotation =
      angle_in_degrees(o.text("false_convergence_rotation"), "--false_convergence_rotation", M_PI);
  if (!(mo.false_convergence_translation > 0.0) || !(mo.false_convergence_rotation > 0.0)) {
    throw Error("false-convergence thresholds must be positive");
  }
  mo.lost_translation = o.number("lost_translation");
  mo.lost_duration = o.number("lost_duration");
  if (!(mo.lost_translation > 0.0) || !(mo.lost_duration >= 0.0) || !std::isfinite(mo.lost_duration)) {
    throw Error("--lost_translation must be positive and --lost_duration a non-negative number of seconds");
  }
  return mo;
}

// --report, or the report.json beside the estimate if there is one; empty: no converged flags to check.
std::string report_file_of(const Options& o, const std::string& estimate_file) {
  if (const auto r = o.maybe("report")) return *r;
  const std::filesystem::path beside = std::filesystem::path(estimate_file).parent_path() / "report.json";
  std::error_code ec;
  if (std::filesystem::is_regular_file(beside, ec)) return beside.string();
  return {};
}

// The "filter_converged" and "false_convergence" entries: the converged flags against the ground truth.
void add_claims_json(nlohmann::json& j, const TrajectoryMetrics& m, const MetricsOptions& mo,
                     const std::string& report_file) {
  if (!m.has_claims) {
    j["filter_converged"] = nullptr;
    j["false_convergence"] = nullptr;
    return;
  }
  j["filter_converged"] = {
      {"claimed_scans", m.claimed_converged},
      {"first_scan",
       m.claimed_converged > 0 ? nlohmann::json(m.errors[m.first_claim_index].truth_index) : nlohmann::json(nullptr)},
      {"first_time_s", m.claimed_converged > 0 ? nlohmann::json(m.first_claim_time) : nlohmann::json(nullptr)}};
  j["false_convergence"] = {
      {"report", report_file},
      {"claimed_converged_scans", m.claimed_converged},
      {"false_claims", m.false_convergence},
      {"first_false_scan",
       m.false_convergence > 0 ? nlohmann::json(m.errors[m.first_false_index].truth_index) : nlohmann::json(nullptr)},
      {"first_false_time_s", m.false_convergence > 0 ? nlohmann::json(m.first_false_time) : nlohmann::json(nullptr)},
      {"thresholds",
       {{"translation_m", mo.false_convergence_translation}, {"rotation_deg", mo.false_convergence_rotation * kDeg}}}};
}

// What evaluate prints: the ground-truth test, the errors after it passed, the converged flags' check.
// "flag_stability": how steady the converged flag is once raised (null without flags or a claim).
void add_flag_stability_json(nlohmann::json& j, const TrajectoryMetrics& m, const std::vector<bool>& claims,
                             const std::vector<std::string>& states) {
  if (!m.has_claims || m.claimed_converged == 0) {
    j["flag_stability"] = nullptr;
    return;
  }
  const FlagStability f = flag_stability(m, claims, &states);
  const auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  j["flag_stability"] = {{"right_scans", f.right_scans},
                         {"right_flagged", f.right_flagged},
                         {"right_flagged_share", number(f.flagged_share())},
                         {"flag_changes", f.flag_changes},
                         {"minutes", f.minutes},
                         {"flag_changes_per_minute", number(f.changes_per_minute())},
                         {"lost_while_right", f.lost_while_right},
                         {"unflagged_right_states", f.unflagged_right_states}};
}

nlohmann::json metrics_json(const TrajectoryMetrics& m, const MetricsOptions& mo, const std::string& estimate_file,
                            const Dataset& dataset, const std::string& report_file, const std::vector<bool>& claims,
                            const std::vector<std::string>& states) {
  nlohmann::json j;
  j["estimate"] = estimate_file;
  j["dataset"] = dataset.dir().string();
  j["scans"] = m.errors.size();
  // "localized" / "localized_from": evaluate's ground-truth test; "converged" / "convergence" are their former
  // names, kept for scripts. The filter's own flag is "filter_converged".
  j["localized"] = m.converged;
  j["localized_from"] =
      m.converged ? nlohmann::json{{"scan", m.errors[m.convergence_index].truth_index}, {"time_s", m.convergence_time}}
                  : nlohmann::json(nullptr);
  j["converged"] = m.converged;
  j["localized_fraction"] = m.localized_fraction;
  j["thresholds"] = {{"translation_m", mo.max_translation_error}, {"rotation_deg", mo.max_rotation_error * kDeg}};
  if (m.converged) {
    const PoseError& first = m.errors[m.convergence_index];
    j["convergence"] = {
        {"estimate_index", m.convergence_index}, {"scan", first.truth_index}, {"time_s", m.convergence_time}};
    j["after_convergence"] = {{"scans", m.converged_count},
                              {"ate_rmse_m", m.ate_rmse},
                              {"rotation_rmse_deg", m.rotation_rmse * kDeg},
                              {"max_translation_error_m", m.max_translation_error},
                              {"max_rotation_error_deg", m.max_rotation_error * kDeg}};
  } else {
    j["convergence"] = nullptr;
    j["after_convergence"] = nullptr;
  }
  add_claims_json(j, m, mo, report_file);
  add_flag_stability_json(j, m, claims, states);
  j["lost_tracks"] = {
      {"episodes", m.lost_tracks},
      {"first_scan", m.lost_tracks > 0 ? nlohmann::json(m.errors[m.first_lost_index].truth_index) : nlohmann::json()},
      {"first_time_s", m.lost_tracks > 0 ? nlohmann::json(m.first_lost_time) : nlohmann::json()},
      {"thresholds", {{"translation_m", mo.lost_translation}, {"duration_s", mo.lost_duration}}}};
  return j;
}

// A simulated scene's landmark (simulate's simulation.json: the symmetric building's display cabinet, the
// two-storey office's staircase): the one thing that tells the building's look-alike places apart. Before a run
// first sees it, which of them is right is a guess no localizer can do better than chance at; the estimates from
// that scan on are what a localizer can be judged on.
struct Landmark {
  std::string name;
  std::optional<std::size_t> first_seen_scan;  // none: the run never sees it
};

// The dataset's landmark, if simulate wrote one. A simulation.json that cannot be read is said and skipped: it
// describes the run, it is not what evaluate measures.
std::optional<Landmark> landmark_of(const Dataset& dataset) {
  const std::filesystem::path file = dataset.dir() / "simulation.json";
  std::error_code ec;
  if (dataset.dir().empty() || !std::filesystem::is_regular_file(file, ec)) return std::nullopt;
  try {
    const nlohmann::json j =
        nlohmann::json::parse(read_input_file(file, "simulation description", limits::kMaxTextFileBytes));
    if (!j.is_object() || !j.contains("landmark") || !j["landmark"].is_object()) return std::nullopt;
    const nlohmann::json& l = j["landmark"];
    Landmark landmark;
    landmark.name = l.value("name", std::string("landmark"));
    const auto scan = l.find("first_seen_scan");
    if (scan != l.end() && !scan->is_null()) {
      if (!scan->is_number_unsigned()) throw Error("landmark.first_seen_scan is not a scan number");
      landmark.first_seen_scan = scan->get<std::size_t>();
    }
    return landmark;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "evaluate: %s is not readable (%s): the landmark is not checked\n", file.c_str(),
                 one_line(e.what()).c_str());
    return std::nullopt;
  }
}

// "after_landmark": the metrics of the estimates from the landmark's first sighting on (null figures where the run
// never sees it or ends first).
nlohmann::json landmark_json(const Landmark& landmark, const TrajectoryMetrics& m,
                             const std::vector<StampedPose>& estimate, const std::vector<bool>* claims,
                             const Dataset& dataset, const MetricsOptions& mo) {
  nlohmann::json j = {{"landmark", landmark.name},     {"first_seen_scan", nullptr},
                      {"first_seen_time_s", nullptr},  {"scans", 0},
                      {"localized_fraction", nullptr}, {"localized_from", nullptr},
                      {"lost_tracks", nullptr},        {"false_claims", nullptr}};
  if (!landmark.first_seen_scan) return j;
  std::vector<StampedPose> after;
  std::vector<bool> after_claims;
  for (std::size_t i = 0; i < m.errors.size(); ++i) {
    if (m.errors[i].truth_index < *landmark.first_seen_scan) continue;
    after.push_back(estimate[i]);
    if (claims) after_claims.push_back((*claims)[i]);
  }
  j["first_seen_scan"] = *landmark.first_seen_scan;
  if (*landmark.first_seen_scan < dataset.times().size()) {
    j["first_seen_time_s"] = dataset.times()[*landmark.first_seen_scan] - m.errors.front().time;
  }
  if (after.empty()) return j;
  const TrajectoryMetrics a =
      evaluate_trajectory(after, dataset.times(), dataset.poses(), mo, claims ? &after_claims : nullptr);
  j["scans"] = after.size();
  j["localized_fraction"] = a.localized_fraction;
  if (a.converged) {
    j["localized_from"] = {{"scan", a.errors[a.convergence_index].truth_index},
                           {"time_s", a.errors[a.convergence_index].time - m.errors.front().time}};
  }
  j["lost_tracks"] = a.lost_tracks;
  if (a.has_claims) j["false_claims"] = a.false_convergence;
  return j;
}

void print_flag_stability(const nlohmann::json& f) {
  if (f.is_null()) return;
  std::fprintf(stderr,
               "evaluate: from the first converged flag on: %zu of %zu right scans flagged converged, %zu flag "
               "changes in %.1f min, %zu right scans flagged lost\n",
               f["right_flagged"].get<std::size_t>(), f["right_scans"].get<std::size_t>(),
               f["flag_changes"].get<std::size_t>(), f["minutes"].get<double>(),
               f["lost_while_right"].get<std::size_t>());
}

void print_landmark_verdict(const nlohmann::json& j) {
  const std::string name = j["landmark"].get<std::string>();
  if (j["first_seen_scan"].is_null()) {
    std::fprintf(stderr,
                 "evaluate: the run never sees the %s, the only thing that tells the building's look-alike places "
                 "apart: which of them is right is a guess\n",
                 name.c_str());
    return;
  }
  if (j["localized_fraction"].is_null()) return;
  std::fprintf(stderr,
               "evaluate: from the first sight of the %s (scan %zu) on: %.1f %% of %zu scans localized, lost "
               "tracks: %zu\n",
               name.c_str(), j["first_seen_scan"].get<std::size_t>(), 100.0 * j["localized_fraction"].get<double>(),
               j["scans"].get<std::size_t>(), j["lost_tracks"].get<std::size_t>());
}

}  // namespace

int run_evaluate(int argc, char** argv) {
  Options o(
      "evaluate",
      "tsdf-mcl evaluate --estimate OUT/trajectory.tum --dataset DIR | --bag FILE --points TOPIC "
      "--ground_truth_topic TOPIC [--plot FILE.png]\n"
      "Two tests, two words: \"localized from scan N\" = every estimate from scan N on lies within the\n"
      "thresholds of the ground truth (evaluate's test); \"converged\" = the filter's own flag in\n"
      "report.json, checked here for false claims. Angles in degrees (or with a unit: 0.1rad).",
      with_bag_options({
          {"estimate", "FILE", "", "estimated trajectory (TUM: t x y z qx qy qz qw, world_T_sensor)"},
          {"dataset", "DIR", "", "dataset whose poses.txt and times.txt are the ground truth"},
          {"plot", "FILE.png", "", "also draw the translation error per axis over time"},
          {"max_translation_error", "M", "0.3", "a scan counts as localized within this distance (m)"},
          {"max_rotation_error", "DEG", "5", "... and within this rotation error (degrees, or e.g. 0.1rad)"},
          {"time_tolerance", "S", "0.02",
           "estimates without an exact timestamp match take the nearest ground truth within this (s)"},
          {"report", "FILE", "",
           "localize's report.json, for its converged flags [default: report.json beside the estimate, if there]"},
          {"false_convergence_translation", "M", "1",
           "a converged flag is false where the estimate is off by more than this (m)"},
          {"false_convergence_rotation", "DEG", "10", "... or by more than this rotation (degrees, or e.g. 0.2rad)"},
          {"lost_translation", "M", "1", "a lost track: after a localized estimate, more than this far off (m) ..."},
          {"lost_duration", "S", "2", "... for longer than this (s)"},
      }),
      argc, argv, 2);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  o.expect_positional(0, "no positional arguments");
  const std::string estimate_file = o.text("estimate");
  if (const auto plot = o.maybe("plot")) {
    check_output_file(*plot, "plot", input_paths(o, {"estimate", "report", "bag", "dataset"}));
  }
  const Dataset dataset = open_dataset(o);
  if (!dataset.has_poses()) throw Error(dataset.missing_poses() + " (ground truth)");
  const MetricsOptions mo = metrics_options(o);
  const std::vector<StampedPose> estimate = read_tum(estimate_file);
  if (estimate.empty()) throw Error("" + estimate_file + " holds no poses");
  const std::string report_file = report_file_of(o, estimate_file);
  std::vector<bool> claims;
  std::vector<std::string> states;
  if (!report_file.empty()) claims = converged_claims(report_file, estimate, &states);
  const TrajectoryMetrics m =
      evaluate_trajectory(estimate, dataset.times(), dataset.poses(), mo, report_file.empty() ? nullptr : &claims);

  nlohmann::json j = metrics_json(m, mo, estimate_file, dataset, report_file, claims, states);
  const std::optional<Landmark> landmark = landmark_of(dataset);
  if (landmark) {
    j["after_landmark"] = landmark_json(*landmark, m, estimate, report_file.empty() ? nullptr : &claims, dataset, mo);
  }
  if (const auto plot = o.maybe("plot")) {
    plot_errors(m, mo, *plot);
    j["plot"] = *plot;
  }
  std::printf("%s\n", j.dump(2).c_str());
  print_verdict(m, mo, report_file);
  print_flag_stability(j["flag_stability"]);
  if (landmark) print_landmark_verdict(j["after_landmark"]);
  return 0;
}

}  // namespace tsdf_mcl::cli
