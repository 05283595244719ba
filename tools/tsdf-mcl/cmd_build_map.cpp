#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include "commands.hpp"
#include "options.hpp"
#include "tsdf_mcl/error.hpp"
#include "tsdf_mcl/map_builder.hpp"
#include "tsdf_mcl/map_io.hpp"

namespace tsdf_mcl::cli {
namespace {

namespace fs = std::filesystem;

// Progress on stderr: one line rewritten in place on a terminal, a line per 10 % in logs.
class ProgressLine {
 public:
  explicit ProgressLine(std::string stage) : stage_(std::move(stage)), tty_(::isatty(STDERR_FILENO) != 0) {}
  ~ProgressLine() {
    if (tty_ && shown_ >= 0) std::fputc('\n', stderr);
  }
  ProgressLine(const ProgressLine&) = delete;
  ProgressLine& operator=(const ProgressLine&) = delete;

  void operator()(std::size_t done, std::size_t total) {
    const int percent = total == 0 ? 100 : static_cast<int>(100 * done / total);
    if (percent == shown_ || (!tty_ && percent / 10 == shown_ / 10 && shown_ >= 0)) return;
    shown_ = percent;
    if (tty_) {
      std::fprintf(stderr, "\rbuild-map: %s %3d%%", stage_.c_str(), percent);
    } else {
      std::fprintf(stderr, "build-map: %s %d%%\n", stage_.c_str(), percent);
    }
    std::fflush(stderr);
  }

 private:
  std::string stage_;
  bool tty_;
  int shown_ = -1;
};

std::string format(const char* fmt, double a, double b = 0.0) {
  char buf[128];
  std::snprintf(buf, sizeof(buf), fmt, a, b);
  return buf;
}

}  // namespace

int run_build_map(int argc, char** argv) {
  Options o("build-map",
            "tsdf-mcl build-map --mesh FILE | --dataset DIR [--start S --stride K --count N] | --import-h5 FILE "
            "[--voxel M] [--truncation M] -o MAP",
            {
                {"mesh", "FILE", "", "triangle mesh (STL, PLY, OBJ; need not be watertight) to build the map from"},
                {"dataset", "DIR", "", "dataset whose scans are integrated at the poses of its poses.txt"},
                {"import-h5", "FILE", "", "HDF5 map of the reference implementation to convert (0.064 m voxels)"},
                {"start", "S", "0", "--dataset: first scan"},
                {"stride", "K", "1", "--dataset: use every K-th scan"},
                {"count", "N", "0", "--dataset: number of scans (0 = all remaining)"},
                {"voxel", "M", "0.05", "voxel size (m); not with --import-h5"},
                {"truncation", "M", "", "truncation distance (m) [default: 0.3; 0.6 with --import-h5]"},
                {"margin", "M", "1.0", "--mesh/--dataset: space added around the mesh or the observed box (m)"},
                {"min-range", "M", "0.3", "--dataset: ignore points closer to the sensor (m)"},
                {"max-range", "M", "60", "--dataset: ignore points farther from the sensor (m)"},
                {"no-free-space", "", "", "--mesh: leave blocks beyond the band unknown instead of filling free space"},
                {"output", "MAP", "", "map file to write"},
            },
            argc, argv, 2);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  if (!o.positional().empty()) {
    throw Error("unexpected argument '" + o.positional().front() + "' (the map file goes after -o)");
  }
  const int sources = static_cast<int>(o.has("mesh")) + static_cast<int>(o.has("dataset")) + static_cast<int>(o.has("import-h5"));
  if (sources == 0) throw Error("no source: give --mesh FILE, --dataset DIR or --import-h5 FILE");
  if (sources > 1) throw Error("give only one source of --mesh, --dataset and --import-h5");
  if (!o.has("output")) throw Error("missing -o MAP (the map file to write)");
  const fs::path output = o.text("output");
  if (output.empty()) throw Error("-o needs a file name");
  const fs::path output_dir = output.has_parent_path() ? output.parent_path() : fs::path(".");
  if (!fs::is_directory(output_dir)) throw Error("output folder " + output_dir.string() + " does not exist");
  if (!o.has("dataset")) {
    for (const char* name : {"start", "stride", "count", "min-range", "max-range"}) {
      if (o.has(name)) throw Error(std::string("build-map: --") + name + " applies to --dataset only");
    }
  }
  if (!o.has("mesh") && o.has("no-free-space")) throw Error("--no-free-space applies to --mesh only");

  const bool h5 = o.has("import-h5");
  if (h5 && (o.has("voxel") || o.has("margin"))) {
    throw Error("--import-h5 keeps the reference map's 0.064 m voxels and extent (no --voxel, --margin)");
  }
  const double voxel = h5 ? 0.064 : o.number("voxel");
  const double truncation = o.has("truncation") ? o.number("truncation") : (h5 ? 0.6 : kDefaultTruncation);
  if (!(voxel > 0.0)) throw Error("--voxel must be positive, got " + o.text("voxel"));
  if (!(truncation >= voxel)) {
    throw Error("--truncation (" + format("%g m", truncation) + ") must be at least the voxel size (" +
                format("%g m", voxel) + ")");
  }
  const double margin = o.number("margin");
  if (margin < 0.0) throw Error("--margin must not be negative");

  const auto started = std::chrono::steady_clock::now();
  TsdfMap map;
  std::string source;
  if (h5) {
    source = o.text("import-h5");
    map = import_reference_h5(source, static_cast<float>(truncation));
  } else if (o.has("mesh")) {
    source = o.text("mesh");
    const TriangleMesh mesh = load_mesh(source);
    std::fprintf(stderr, "build-map: %s: %zu vertices, %zu triangles\n", source.c_str(), mesh.vertices.size(),
                 mesh.triangles.size());
    MeshMapOptions options;
    options.voxel_size = static_cast<float>(voxel);
    options.truncation = static_cast<float>(truncation);
    options.margin = static_cast<float>(margin);
    options.fill_free_space = !o.flag("no-free-space");
    ProgressLine progress("signed distances");
    map = build_map_from_mesh(mesh, options, std::ref(progress));
  } else {
    source = o.text("dataset");
    const Dataset dataset = Dataset::open(source);
    if (!dataset.has_poses()) {
      throw Error("dataset " + source + " has no poses.txt (scans are integrated at their world_T_sensor poses)");
    }
    const ScanSelection selection{o.count("start"), o.count("stride"), o.count("count")};
    const std::vector<std::size_t> scans = selection.indices(dataset.size());
    if (scans.empty()) {
      throw Error("--start " + o.text("start") + " --stride " + o.text("stride") + " --count " +
                  o.text("count") + " selects none of the " + std::to_string(dataset.size()) + " scans");
    }
    ScanMapOptions options;
    options.voxel_size = static_cast<float>(voxel);
    options.truncation = static_cast<float>(truncation);
    options.margin = static_cast<float>(margin);
    options.min_range = static_cast<float>(o.number("min-range"));
    options.max_range = static_cast<float>(o.number("max-range"));
    std::fprintf(stderr, "build-map: integrating %zu of %zu scans of %s\n", scans.size(), dataset.size(), source.c_str());
    ProgressLine progress("integrating scans");
    map = build_map_from_scans(dataset, scans, options, std::ref(progress));
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  save_map(map, output);
  const TsdfMap::Stats s = map.stats();
  std::fprintf(stderr,
               "build-map: wrote %s: %.3f m voxels, truncation %.3f m, %zu blocks + %zu free blocks, %.1f MiB, "
               "built in %.1f s\n",
               output.c_str(), static_cast<double>(map.voxel_size()), static_cast<double>(map.truncation()),
               s.allocated_blocks, s.free_blocks, static_cast<double>(s.memory_bytes) / (1024.0 * 1024.0), seconds);
  return 0;
}

}  // namespace tsdf_mcl::cli
