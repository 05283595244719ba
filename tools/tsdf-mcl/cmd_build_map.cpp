#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>

#include "commands.hpp"
#include "dataset_source.hpp"
#include "options.hpp"
#include "progress.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/io/cloud_io.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "tsdf_mcl/mapping/h5_import.hpp"

namespace tsdf_mcl::cli {
namespace {

// The valid --voxel and --truncation (m): a map of 2 m voxels locates nothing; a band of more than 64 voxels or
// 10 m makes every ray cost thousands of voxel updates.
constexpr double kMinVoxel = 0.005, kMaxVoxel = 2.0;
constexpr double kMaxTruncationVoxels = 64.0, kMaxTruncation = 10.0;

namespace fs = std::filesystem;

// A build stage's progress (progress.hpp: a live line on a terminal, a line every few seconds in a log). Nothing
// in the first second: bad input fails within it with its error as the only line, and short builds need none.
class ProgressLine {
 public:
  ProgressLine(Progress& progress, std::string stage)
      : progress_(progress), stage_(std::move(stage)), started_(std::chrono::steady_clock::now()) {}

  void operator()(std::size_t done, std::size_t total) {
    if (std::chrono::steady_clock::now() - started_ < std::chrono::seconds(1)) return;
    progress_.update(done, total, stage_);
  }

 private:
  Progress& progress_;
  std::string stage_;
  std::chrono::steady_clock::time_point started_;
};

std::string format(const char* fmt, double a, double b = 0.0) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), fmt, a, b);
  return buf;
}

// The poses of `trajectory` at the dataset's scan times become its poses; the selected scans outside the
// trajectory's times are left out (said on stderr). Returns the scans kept.
std::vector<std::size_t> use_trajectory(Dataset& dataset, const std::vector<StampedPose>& trajectory,
                                        const std::vector<std::size_t>& scans, const std::string& file) {
  if (trajectory.empty()) throw Error(file + " holds no poses");
  std::vector<Pose> poses(dataset.size(), Pose::Identity());
  std::vector<std::size_t> kept;
  for (std::size_t i = 0; i < dataset.size(); ++i) {
    const std::optional<Pose> p = pose_at(trajectory, dataset.time(i));
    if (p) poses[i] = *p;
    if (p && std::binary_search(scans.begin(), scans.end(), i)) kept.push_back(i);
  }
  if (kept.empty()) {
    throw Error(file + " (" + format("%.3f..%.3f s", trajectory.front().time, trajectory.back().time) +
                ") covers none of the selected scans' times");
  }
  if (kept.size() < scans.size()) {
    std::fprintf(stderr, "build-map: %zu of the %zu selected scans lie outside the times of %s: left out\n",
                 scans.size() - kept.size(), scans.size(), file.c_str());
  }
  dataset.set_poses(std::move(poses));
  return kept;
}

// build-map's options: one source, the map's geometry, the scans' ranges, the budget, the output.
std::vector<OptionSpec> build_map_options() {
  return with_verbosity_options(with_bag_options({
      {"mesh", "FILE", "", "triangle mesh (STL, PLY, OBJ; need not be watertight) to build the map from"},
      {"dataset", "DIR", "", "dataset whose scans are integrated at the poses of its poses.txt"},
      {"cloud", "FILE", "", "point cloud map (.pcd ascii/binary/binary_compressed, .ply) to build the map from"},
      {"trajectory", "FILE", "",
       "the mapping run's trajectory. --dataset/--bag: integrate the scans at these poses (TUM, world_T_sensor, "
       "interpolated at the scans' times) instead of the ground truth; scans outside its times are left out. "
       "--cloud: the sensor positions (a TUM file or a dataset folder's poses.txt), which orient normals and "
       "carve free space along sight lines"},
      {"import_h5", "FILE", "", "HDF5 map of the reference implementation to convert (0.064 m voxels)"},
      {"start", "S", "0", "--dataset: first scan"},
      {"stride", "K", "1", "--dataset: use every K-th scan"},
      {"count", "N", "0", "--dataset: number of scans (0 = all remaining)"},
      {"voxel", "M", "0.05", "voxel size (m); not with --import_h5"},
      {"truncation", "M", "", "truncation distance (m) [default: 0.3; 0.6 with --import_h5]"},
      {"margin", "M", "1.0", "--mesh/--dataset: space added around the mesh or the observed box (m)"},
      {"laser_min_range", "M", "0.3", "--dataset: ignore points closer to the sensor (m)"},
      {"laser_max_range", "M", "60",
       "--dataset: ignore points farther from the sensor (m); --cloud --trajectory: "
       "farthest point a trajectory position sees"},
      {"no_free_space", "", "",
       "--mesh: leave blocks beyond the band unknown instead of filling free space; --cloud: "
       "free space along sight lines only, no filling of enclosed regions"},
      {"max_memory", "MIB", std::to_string(limits::kDefaultBuildMemoryMiB),
       "memory budget of the build (the map and the builder's buffers); building stops with an error past it"},
      {"output", "MAP", "", "map file to write"},
  }));
}

// Exactly one source, an output file, and no option that the chosen source would ignore.
void check_sources_and_output(const Options& o) {
  if (!o.positional().empty()) {
    throw Error("unexpected argument '" + o.positional().front() + "' (the map file goes after -o)");
  }
  const bool scans_source = o.has("dataset") || o.has("bag");
  const int sources = static_cast<int>(o.has("mesh")) + static_cast<int>(o.has("dataset")) +
                      static_cast<int>(o.has("bag")) + static_cast<int>(o.has("cloud")) +
                      static_cast<int>(o.has("import_h5"));
  if (sources == 0)
    throw Error("no source: give --mesh FILE, --dataset DIR, --bag FILE, --cloud FILE or --import_h5 FILE");
  if (sources > 1) throw Error("give only one source of --mesh, --dataset, --bag, --cloud and --import_h5");
  if (!o.has("output")) throw Error("missing -o MAP (the map file to write)");
  const fs::path output = o.text("output");
  if (output.empty()) throw Error("-o needs a file name");
  check_output_file(output, "map");
  if (!scans_source) {
    for (const char* name : {"start", "stride", "count", "laser_min_range"}) {
      if (o.has(name)) throw Error(std::string("build-map: --") + name + " applies to --dataset and --bag only");
    }
    for (const char* name : {"laser_max_range", "trajectory"}) {
      if (o.has(name) && !o.has("cloud")) {
        throw Error(std::string("build-map: --") + name + " applies to --dataset, --bag and --cloud only");
      }
    }
  }
  if (!o.has("mesh") && !o.has("cloud") && o.has("no_free_space"))
    throw Error("--no_free_space applies to --mesh and --cloud only");
}

// The map's geometry and the build's memory budget, checked.
struct BuildGeometry {
  double voxel = 0.0;
  double truncation = 0.0;
  double margin = 0.0;
  std::uint64_t max_memory = 0;  // bytes
};

BuildGeometry build_geometry(const Options& o, bool h5) {
  if (h5 && (o.has("voxel") || o.has("margin"))) {
    throw Error("--import_h5 keeps the reference map's 0.064 m voxels and extent (no --voxel, --margin)");
  }
  BuildGeometry g;
  g.voxel = h5 ? 0.064 : o.number("voxel");
  g.truncation = o.has("truncation") ? o.number("truncation") : (h5 ? 0.6 : kDefaultTruncation);
  if (!(g.voxel >= kMinVoxel && g.voxel <= kMaxVoxel)) {
    throw Error("--voxel must be in " + format("%g..%g m", kMinVoxel, kMaxVoxel) + ", got " + o.text("voxel"));
  }
  // The band integrated around every ray is truncation / voxel voxels deep: bounded so a build ends in its time.
  const double max_truncation = std::min(kMaxTruncationVoxels * g.voxel, kMaxTruncation);
  if (!(g.truncation >= g.voxel && g.truncation <= max_truncation)) {
    throw Error("--truncation must be in " + format("%g..%g m", g.voxel, max_truncation) + " (at least the voxel, " +
                "at most " + format("%g", kMaxTruncationVoxels) + " voxels and " + format("%g m", kMaxTruncation) +
                "), got " + format("%g m", g.truncation));
  }
  g.margin = o.number("margin");
  if (g.margin < 0.0) throw Error("--margin must not be negative");
  g.max_memory = std::uint64_t{o.count("max_memory", std::size_t{1} << 30)} << 20;
  return g;
}

TsdfMap map_from_mesh(const Options& o, const BuildGeometry& g, const std::string& source, Progress& progress_out) {
  const TriangleMesh mesh = load_mesh(source);
  MeshMapOptions options;
  options.voxel_size = static_cast<float>(g.voxel);
  options.truncation = static_cast<float>(g.truncation);
  options.margin = static_cast<float>(g.margin);
  options.fill_free_space = !o.flag("no_free_space");
  options.max_memory_bytes = g.max_memory;
  ProgressLine progress(progress_out, source + " (" + std::to_string(mesh.vertices.size()) + " vertices, " +
                                          std::to_string(mesh.triangles.size()) + " triangles): signed distances");
  return build_map_from_mesh(mesh, options, std::ref(progress));
}

TsdfMap map_from_cloud(const Options& o, const BuildGeometry& g, const std::string& source, Progress& progress_out,
                       Verbosity verbosity) {
  CloudMapOptions options;
  options.voxel_size = static_cast<float>(g.voxel);
  options.truncation = static_cast<float>(g.truncation);
  options.margin = static_cast<float>(g.margin);
  options.max_range = static_cast<float>(o.number("laser_max_range"));
  options.fill_free_space = !o.flag("no_free_space");
  options.max_memory_bytes = g.max_memory;
  if (o.has("trajectory")) options.trajectory = read_trajectory_positions(o.text("trajectory"));
  CloudReader reader(source, g.max_memory);
  CloudMapReport report;
  TsdfMap map;
  {
    ProgressLine progress(progress_out,
                          source + " (" + reader.format() + ", " + std::to_string(reader.size_hint()) + " points)");
    map = build_map_from_cloud(reader, options, std::ref(progress), &report);
  }
  if (verbosity != Verbosity::kQuiet) std::fprintf(stderr, "%s", describe(report).c_str());
  return map;
}

// A dataset's or a bag's scans, integrated at their ground-truth poses or at --trajectory's.
TsdfMap map_from_scans(const Options& o, const BuildGeometry& g, const std::string& source, Progress& progress_out) {
  Dataset dataset = open_dataset(o);
  const ScanSelection selection{o.count("start"), o.count("stride"), o.count("count")};
  std::vector<std::size_t> scans = selection.indices(dataset.size());
  if (scans.empty()) {
    throw Error("--start " + o.text("start") + " --stride " + o.text("stride") + " --count " + o.text("count") +
                " selects none of the " + std::to_string(dataset.size()) + " scans");
  }
  if (const auto trajectory_file = o.maybe("trajectory")) {
    scans = use_trajectory(dataset, read_tum(*trajectory_file), scans, *trajectory_file);
  } else if (!dataset.has_poses()) {
    throw Error(dataset.missing_poses() +
                " (scans are integrated at their world_T_sensor poses; or give --trajectory FILE.tum)");
  }
  if (!dataset.summary().empty()) progress_out.note(dataset.summary());
  ScanMapOptions options;
  options.voxel_size = static_cast<float>(g.voxel);
  options.truncation = static_cast<float>(g.truncation);
  options.margin = static_cast<float>(g.margin);
  options.min_range = static_cast<float>(o.number("laser_min_range"));
  options.max_range = static_cast<float>(o.number("laser_max_range"));
  options.max_memory_bytes = g.max_memory;
  dataset.check_scans_not_empty(scans);
  ProgressLine progress(progress_out, "integrating " + std::to_string(scans.size()) + " of " +
                                          std::to_string(dataset.size()) + " scans of " + source);
  return build_map_from_scans(dataset, scans, options, std::ref(progress));
}

// The map from the one source the options name.
TsdfMap build_map(const Options& o, const BuildGeometry& g, const fs::path& output, Progress& progress_out,
                  Verbosity verbosity) {
  if (o.has("import_h5")) {
    // Beside the output: the scratch map is as large as the map, which the system's temporary folder may not hold.
    return import_reference_h5_isolated(o.text("import_h5"), static_cast<float>(g.truncation), g.max_memory,
                                        std::filesystem::absolute(output).parent_path());
  }
  if (o.has("mesh")) return map_from_mesh(o, g, o.text("mesh"), progress_out);
  if (o.has("cloud")) return map_from_cloud(o, g, o.text("cloud"), progress_out, verbosity);
  return map_from_scans(o, g, o.has("bag") ? o.text("bag") : o.text("dataset"), progress_out);
}

// The closing line: the file, the map's resolution, blocks and memory, the build's time.
std::string summary_line(const TsdfMap& map, const fs::path& output, double seconds) {
  const TsdfMap::Stats s = map.stats();
  char line[600];
  std::snprintf(line, sizeof(line),
                "wrote %s: %.3f m voxels, truncation %.3f m, %zu blocks + %zu free blocks, %.1f MiB, built in %.1f s",
                output.c_str(), static_cast<double>(map.voxel_size()), static_cast<double>(map.truncation()),
                s.allocated_blocks, s.free_blocks, static_cast<double>(s.memory_bytes) / (1024.0 * 1024.0), seconds);
  return line;
}

}  // namespace

int run_build_map(int argc, char** argv) {
  Options o("build-map",
            "tsdf-mcl build-map --mesh FILE | --dataset DIR [--start S --stride K --count N]\n"
            "                          | --cloud FILE [--trajectory FILE.tum|DIR] | --import_h5 FILE\n"
            "                          [--voxel M] [--truncation M] -o MAP\n"
            "       tsdf-mcl build-map --bag FILE --points TOPIC --ground_truth_topic TOPIC | --trajectory FILE.tum\n"
            "                          ... -o MAP",
            build_map_options(), argc, argv, 2);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  check_sources_and_output(o);
  const fs::path output = o.text("output");
  const BuildGeometry g = build_geometry(o, o.has("import_h5"));

  const Verbosity verbosity = verbosity_of(o);
  Progress progress_out("build-map", verbosity);
  const auto started = std::chrono::steady_clock::now();
  const TsdfMap map = build_map(o, g, output, progress_out, verbosity);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  save_map(map, output);
  progress_out.summary(summary_line(map, output, seconds));
  return 0;
}

}  // namespace tsdf_mcl::cli
