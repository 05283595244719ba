// tsdf-mcl: global 6-DoF Monte Carlo localization of a LiDAR in a TSDF map (see README.md).
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "commands.hpp"
#include "run_command.hpp"
#include "tsdf_mcl/core/one_line.hpp"
#include "tsdf_mcl/localizer/localizer_parameters.hpp"

namespace {

struct Command {
  const char* name;
  int (*run)(int, char**);
  const char* summary;
};

constexpr Command kCommands[] = {
    {"build-map", tsdf_mcl::cli::run_build_map,
     "build a TSDF map from a mesh, a dataset's scans, a point cloud or an HDF5 map"},
    {"info", tsdf_mcl::cli::run_info, "print a map's resolution, extent, blocks, memory and known/free volume"},
    {"simulate", tsdf_mcl::cli::run_simulate, "simulate a LiDAR driving through a scene; writes a dataset"},
    {"localize", tsdf_mcl::cli::run_localize,
     "run the particle filter over a dataset; writes trajectory.tum, report.json"},
    {"evaluate", tsdf_mcl::cli::run_evaluate, "compare an estimated trajectory with the dataset's ground truth"},
    {"bench", tsdf_mcl::cli::run_bench, "time the sensor update per backend and particle count (JSON lines)"},
    {"render", tsdf_mcl::cli::run_render, "draw a map, particles and trajectories to PNG"},
    {"export-cloud", tsdf_mcl::cli::run_export_cloud, "write a dataset's scans at their poses as one world-frame PCD"},
};

void print_usage(std::FILE* out) {
  std::fprintf(out,
               "usage: tsdf-mcl <command> [options]   (tsdf-mcl <command> --help for its options)\n"
               "       tsdf-mcl --version\n\ncommands:\n");
  for (const auto& c : kCommands) std::fprintf(out, "  %-13s %s\n", c.name, c.summary);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "help")) {
    print_usage(argc < 2 ? stderr : stdout);
    return argc < 2 ? 2 : 0;
  }
  if (!std::strcmp(argv[1], "--version") || !std::strcmp(argv[1], "version")) {
    std::printf("tsdf-mcl %s\n", TSDF_MCL_VERSION);
    return 0;
  }
  for (const auto& c : kCommands) {
    if (std::strcmp(argv[1], c.name) == 0) return tsdf_mcl::cli::run_command(c.name, c.run, argc, argv);
  }
  std::vector<std::string> names;
  for (const auto& c : kCommands) names.push_back(c.name);
  const std::string close = tsdf_mcl::did_you_mean(argv[1], names, "tsdf-mcl ");
  std::fprintf(stderr, "tsdf-mcl: unknown command '%s'%s; tsdf-mcl --help lists the commands\n",
               tsdf_mcl::one_line(argv[1]).c_str(), close.c_str());
  return 2;
}
