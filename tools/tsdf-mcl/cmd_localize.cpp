#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "dataset_source.hpp"
#include "options.hpp"
#include "output_folder.hpp"
#include "localize_parameters.hpp"
#include "localize_progress.hpp"
#include "progress.hpp"
#include "tsdf_mcl/core/stopwatch.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/one_line.hpp"
#include "tsdf_mcl/io/imu.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/localizer/localization_report.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"
#include "tsdf_mcl/localizer/map_extent_checks.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "tsdf_mcl/filter/particle_filter.hpp"
#include "tsdf_mcl/io/particle_snapshot.hpp"
#include "tsdf_mcl/filter/scan_preprocessing.hpp"
#include "tsdf_mcl/localizer/last_pose_file.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl::cli {
namespace {

namespace fs = std::filesystem;
constexpr double kImuLookAhead = 0.1;  // s: the window imu_up_at averages over around a scan

// The command's own inputs, then the parameters it shares with every frontend (localize_parameters.hpp).
std::vector<OptionSpec> localize_options() {
  std::vector<OptionSpec> specs = {
      {"map", "FILE", "", "TSDF map (tsdf-mcl build-map)", "input"},
      {"dataset", "DIR", "", "dataset: scans/, times.txt, odom.txt (poses.txt is not used)", "input"},
      {"start", "S", "0", "first scan", "input"},
      {"stride", "K", "1", "take every K-th scan", "input"},
      {"count", "N", "0", "number of scans (0 = all from start)", "input"},
      {"config", "FILE", "",
       "YAML or JSON file of parameters by their option names (nested maps join with '.'); command-line flags win",
       "input"},
      {"output", "DIR", "",
       "output folder for trajectory.tum (every scan's estimate, the search phase included) and "
       "report.json",
       "output"},
      {"overwrite", "", "", "replace the results of an earlier run in the output folder (refused without it)",
       "output"},
      {"last_pose_file", "FILE", "",
       "keep the last converged pose in FILE and start from it when it holds one for this map and no --init pose "
       "is given; a scan that does not fit there searches the whole map (off by default; the ROS nodes keep one)",
       "input"},
      {"snapshot_every", "K", "0",
       "write the particle set to OUT/snapshots/ after initialization and every K-th scan (0 = never), for tsdf-mcl "
       "render --particles",
       "output"},
  };
  for (OptionSpec& s : localize_parameter_specs()) specs.push_back(std::move(s));
  return with_verbosity_options(std::move(specs));
}

// Every option's effective value, numbers as numbers.
nlohmann::json parameters_json(const Options& o) {
  nlohmann::json j = nlohmann::json::object();
  for (const OptionSpec& s : o.specs()) {
    if (s.value_name.empty()) {
      j[s.name] = o.flag(s.name);
      continue;
    }
    const auto v = o.maybe(s.name);
    if (!v) {
      j[s.name] = nullptr;
      continue;
    }
    char* end = nullptr;
    const double d = std::strtod(v->c_str(), &end);
    if (!v->empty() && *end == '\0' && std::isfinite(d))
      j[s.name] = d;
    else
      j[s.name] = *v;
  }
  return j;
}

// An earlier run's results are kept unless the user says to replace them.
void refuse_earlier_results(const Options& o) {
  for (const char* earlier : {"report.json", "trajectory.tum"}) {
    if (!o.flag("overwrite") && fs::exists(fs::path(o.text("output")) / earlier)) {
      throw Error(one_line(o.text("output")) + " holds an earlier run's results (" + earlier +
                  "); pass --overwrite to replace them or choose another -o");
    }
  }
}

// The scans --start/--stride/--count pick, checked against what the run needs before any work starts.
std::vector<std::size_t> selected_scans(const Options& o, const Dataset& dataset, const LocalizerOptions& lo) {
  ScanSelection selection;
  selection.start = o.count("start");
  selection.stride = o.count("stride");
  selection.count = o.count("count");
  const std::vector<std::size_t> scans = selection.indices(dataset.size());
  if (scans.empty()) {
    throw Error("--start " + std::to_string(selection.start) + " selects no scan (the dataset has " +
                std::to_string(dataset.size()) + ")");
  }
  if (lo.filter.motion.type == MotionModelType::kOdometry && !dataset.has_odometry()) {
    throw Error(dataset.missing_odometry() +
                ", which motion_model odometry needs (or use --motion_model constant_velocity or diffusion)");
  }
  // Empty scan files are caught before any work starts; scans whose points are all NaN or out of range can
  // only be found while reading them.
  dataset.check_scans_not_empty(scans);
  return scans;
}

// The selected scans' odometry against the map before any work starts, as the localizer would check each scan's
// (map_extent_checks.hpp): a jump found there would end the run after its first scans.
void check_odometry_steps(const Dataset& dataset, const std::vector<std::size_t>& scans, const TsdfMap& map) {
  if (!dataset.has_odometry()) return;
  std::optional<Pose> previous;
  for (const std::size_t i : scans) {
    check_odometry(map, dataset.odometry(i), previous, dataset.scan_path(i).string() + ": the scan's odometry");
    previous = dataset.odometry(i);
  }
}

// --snapshot_every: where the particle sets go and how often.
struct Snapshots {
  std::size_t every = 0;
  fs::path dir;
  bool due(std::size_t k) const { return every > 0 && k % every == 0; }
};

Snapshots prepare_snapshots(const Options& o, const fs::path& out_dir, const LocalizerOptions& lo,
                            const Localizer& localizer) {
  Snapshots snapshots{o.count("snapshot_every"), out_dir / "snapshots"};
  if (snapshots.every > 0) {
    std::error_code ec;
    fs::create_directories(snapshots.dir, ec);
    if (ec) throw Error("cannot create " + snapshots.dir.string() + ": " + ec.message());
    if (lo.initial_pose) write_particle_snapshot(snapshots.dir / "init.bin", localizer.snapshot());
  }
  return snapshots;
}

// One line on how the filter started: around the initial pose, or what the global search found.
void report_initialization(Progress& progress, const Localizer& localizer, const Snapshots& snapshots) {
  const InitializationRecord& init = *localizer.initialization();
  if (!init.global) {
    progress.note(std::to_string(init.particles) + " particles around the initial pose");
    return;
  }
  std::string heights;
  for (const GravityCandidate& c : init.candidates) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%s%.2f", heights.empty() ? "" : ",",
                  c.has_height ? static_cast<double>(c.height) : NAN);
    heights += buf;
  }
  char line[400];
  std::snprintf(line, sizeof(line),
                "global search: %zu up-direction candidates from the first scan%s (sensor heights %s m); best "
                "%zu of %zu hypotheses over %zu free-space voxels kept",
                init.candidates.size(), init.gravity_source == "imu" ? " and the IMU" : "",
                heights.empty() ? "-" : heights.c_str(), init.particles, init.hypotheses_scored,
                init.free_space_voxels);
  progress.note(line);
  if (snapshots.every > 0) write_particle_snapshot(snapshots.dir / "init.bin", localizer.snapshot());
}

// What the scan loop leaves for the report and the summary line.
struct LocalizeRun {
  std::vector<StampedPose> trajectory;
  std::size_t dropped_total = 0;
  double run_s = 0.0;
};

// Every selected scan through the localizer, each one's record appended to the report writer.
LocalizeRun localize_scans(const Dataset& dataset, const std::vector<std::size_t>& scans,
                           const std::vector<ImuSample>& imu, Localizer& localizer, const Snapshots& snapshots,
                           const StagedOutputFolder& output, Progress& progress, ReportWriter& report_writer,
                           LocalizeNarrator& narrator, bool reported_init, LastPoseFile* last_pose) {
  LocalizeRun run;
  std::size_t imu_next = 0;
  const Stopwatch t_run;
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const std::size_t idx = scans[k];
    const Stopwatch t0;
    std::size_t dropped = 0;
    const PointCloud cloud = dataset.load_scan(idx, &dropped);
    const double load_ms = t0.ms();
    run.dropped_total += dropped;
    const std::optional<Pose> odometry =
        dataset.has_odometry() ? std::optional<Pose>(dataset.odometry(idx)) : std::nullopt;
    while (imu_next < imu.size() && imu[imu_next].time <= dataset.time(idx) + kImuLookAhead)
      localizer.add_imu(imu[imu_next++]);
    const ScanRecord* record = nullptr;
    try {
      record = &localizer.process(dataset.time(idx), cloud.points, odometry, idx);
    } catch (const Error& e) {
      throw Error(dataset.scan_path(idx).string() + ": " + e.what());
    }
    if (!reported_init) {
      report_initialization(progress, localizer, snapshots);
      reported_init = true;
    }
    const FilterStep& step = record->step;
    run.trajectory.push_back({dataset.time(idx), step.estimate.pose});

    nlohmann::json j = scan_json(*record);
    j["scan"] = idx;
    j["points"]["raw"] = cloud.size() + dropped;
    j["points"]["dropped_non_finite"] = dropped;
    j["timings_ms"]["load"] = load_ms;
    if (snapshots.due(k)) {
      char name[32];
      std::snprintf(name, sizeof(name), "scan_%06zu.bin", idx);
      write_particle_snapshot(snapshots.dir / name, localizer.snapshot());
      j["snapshot"] = (output.folder() / "snapshots" / name).string();
    }
    report_writer.add(j);

    narrator.scan(k, idx, *record, dropped);
    if (last_pose) {
      if (const std::string note = last_pose->follow(localizer, *record); !note.empty()) progress.note(note);
    }
  }
  if (last_pose) last_pose->flush();
  run.run_s = t_run.ms() / 1000.0;
  return run;
}

// report.json's "summary": the localizer's own, with what only the command knows (scan numbers, drops, time).
nlohmann::json summary_entry_json(const RunSummary& summary, const LocalizerOptions& lo, const LocalizeRun& run,
                                  const Dataset& dataset, const std::vector<std::size_t>& scans,
                                  const LocalizeNarrator& narrator, const std::optional<std::size_t>& converged_since) {
  nlohmann::json summary_entry = summary_json(summary);
  summary_entry["particles"]["initial"] = lo.filter.initial_particles;
  summary_entry["dropped_non_finite_points"] = run.dropped_total;
  summary_entry["converged_since_scan"] = converged_since ? nlohmann::json(*converged_since) : nlohmann::json(nullptr);
  // The filter's own flag, first raised (evaluate's "localized from" is the ground-truth test).
  summary_entry["first_converged_scan"] =
      narrator.first_converged_scan() ? nlohmann::json(*narrator.first_converged_scan()) : nlohmann::json(nullptr);
  summary_entry["converged_since_s"] = summary.converged_since_time
                                           ? nlohmann::json(*summary.converged_since_time - dataset.time(scans.front()))
                                           : nlohmann::json(nullptr);
  summary_entry["wall_s"] = run.run_s;
  return summary_entry;
}

// report.json: the command, the backend, the map and dataset, every parameter, the initialization and the summary.
nlohmann::json report_json(const Options& o, const Localizer& localizer, const TsdfMap& map, const Dataset& dataset,
                           const std::vector<std::size_t>& scans, nlohmann::json summary_entry) {
  nlohmann::json report;
  report["command"] = "localize";
  report["version"] = TSDF_MCL_VERSION;
  report["backend"] = localizer.evaluator().backend();
  report["device"] = localizer.evaluator().device_name();
  if (!localizer.evaluator().weight_layout().empty()) report["weight_layout"] = localizer.evaluator().weight_layout();
  report["backend_note"] = localizer.backend_note();
  report["map"] = {{"file", o.text("map")}, {"voxel_size", map.voxel_size()}, {"truncation", map.truncation()}};
  report["dataset"] = {{"dir", dataset.dir().string()}, {"scans", dataset.size()}, {"selected", scans.size()}};
  report["parameters"] = parameters_json(o);
  report["initialization"] = initialization_json(*localizer.initialization());
  report["summary"] = std::move(summary_entry);
  return report;
}

// The run's closing line: counts, timings, particles, the verdict, scans by state, the files written.
std::string summary_line(const RunSummary& summary, const LocalizerOptions& lo, const LocalizeRun& run,
                         std::size_t scan_count, const LocalizeNarrator& narrator,
                         const std::optional<std::size_t>& converged_since, const fs::path& folder) {
  std::string states;
  for (std::size_t s = 0; s < kTrackStates; ++s) {
    if (summary.state_scans[s] == 0) continue;
    states += " " + std::string(to_string(static_cast<TrackState>(s))) + " " + std::to_string(summary.state_scans[s]);
  }
  char line[1024];
  std::snprintf(line, sizeof(line),
                "%zu scans, %zu filter updates in %.1f s (update mean %.1f ms, median %.1f ms); particles %zu initial, "
                "%zu..%zu, %zu final; %s; scans by state:%s; wrote %s and %s",
                scan_count, summary.updates, run.run_s, summary.update_ms_mean, summary.update_ms_median,
                lo.filter.initial_particles, summary.particles_min, summary.particles_max, summary.particles_final,
                narrator.verdict(summary, converged_since).c_str(), states.c_str(), (folder / "trajectory.tum").c_str(),
                (folder / "report.json").c_str());
  return line;
}

}  // namespace

int run_localize(int argc, char** argv) {
  // docs/parameters.md, generated from the parameter table.
  if (argc == 3 && std::string(argv[2]) == "--help-markdown") {
    std::printf("%s", parameters_markdown().c_str());
    return 0;
  }
  Options o("localize",
            "tsdf-mcl localize --map MAP --dataset DIR | --bag FILE --points TOPIC -o OUT\n"
            "           [--init global|x,y,z,roll,pitch,yaw|initial_pose] [--particles N] [--config FILE] [...]\n"
            "Writes OUT/trajectory.tum (world_T_sensor for every scan, the search phase included) and\n"
            "OUT/report.json. Angles are in radians as in nav2 (initial_pose.yaw, update_min_a, --init's roll,\n"
            "pitch, yaw); any angle also takes a unit: 90deg, 1.57rad. report.json and evaluate print degrees.\n"
            "A filter parameter also comes from a --config file or, in the ROS node, the parameter server.\n"
            "--help-all lists the expert options too; --help-markdown prints docs/parameters.md.",
            with_bag_options(localize_options()), argc, argv, 2);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  o.expect_positional(0, "no positional arguments");
  if (const auto config = o.maybe("config")) apply_config(o, *config);

  LocalizerOptions lo = localizer_options(o);
  if (!o.maybe("output")) throw Error("missing -o OUT (the output folder)");
  refuse_earlier_results(o);
  StagedOutputFolder output(o.text("output"), {"trajectory.tum", "report.json", "snapshots"});
  const fs::path out_dir = output.staging();
  const Dataset dataset = open_dataset(o);
  const std::vector<std::size_t> scans = selected_scans(o, dataset, lo);
  // An IMU's gravity, where the dataset has one, stands for the up direction the scan would suggest. Samples are
  // fed as a live IMU would deliver them: up to just past each scan's time.
  const std::vector<ImuSample> imu = lo.use_imu ? dataset.imu() : std::vector<ImuSample>{};
  const TsdfMap map = load_map(o.text("map"));
  check_odometry_steps(dataset, scans, map);
  Progress progress("localize", verbosity_of(o), "scans");
  const LocalizerOptions requested = lo;  // the narrator explains a misfit of a requested pose, not of a kept one
  std::unique_ptr<LastPoseFile> last_pose;
  if (const auto file = o.maybe("last_pose_file")) {
    last_pose = std::make_unique<LastPoseFile>(*file, map);
    std::string note, warning;
    if (const std::optional<Pose> kept = last_pose->start(lo, &note, &warning)) lo.initial_pose = kept;
    if (!warning.empty()) progress.note(warning);
    if (!note.empty()) progress.note(note);
  }
  Localizer localizer(map, lo);
  if (!dataset.summary().empty()) progress.note(dataset.summary());
  progress.note(localizer.backend_note());

  const Snapshots snapshots = prepare_snapshots(o, out_dir, lo, localizer);
  // A known initial pose is reported now; a global search only once the first scan has run it.
  if (lo.initial_pose) report_initialization(progress, localizer, snapshots);

  ReportWriter report_writer(out_dir / "scans.jsonl");
  LocalizeNarrator narrator(progress, requested, scans.size());
  const LocalizeRun run = localize_scans(dataset, scans, imu, localizer, snapshots, output, progress, report_writer,
                                         narrator, lo.initial_pose.has_value(), last_pose.get());

  write_tum(out_dir / "trajectory.tum", run.trajectory);
  const RunSummary summary = localizer.summary();
  const std::optional<std::size_t> converged_since =
      summary.converged_since_index ? std::optional<std::size_t>(scans[*summary.converged_since_index]) : std::nullopt;
  report_writer.write(report_json(o, localizer, map, dataset, scans,
                                  summary_entry_json(summary, lo, run, dataset, scans, narrator, converged_since)),
                      out_dir / "report.json");
  output.commit();
  progress.summary(summary_line(summary, lo, run, scans.size(), narrator, converged_since, output.folder()));
  return 0;
}

}  // namespace tsdf_mcl::cli
