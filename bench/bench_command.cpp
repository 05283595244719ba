#include "bench_command.hpp"

#include <cstdio>
#include <sstream>
#include <string>

#include "options.hpp"
#include "sensor_update_bench.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/map/map_io.hpp"

namespace tsdf_mcl::bench {

using cli::Options;
using cli::OptionSpec;

namespace {

// A default share as the help prints it (0.2, not 0.200000).
std::string share_text(double share) {
  std::ostringstream text;
  text << share;
  return text.str();
}

// bench's options: the scene, the particle counts and spread, the weighing, the backends, the model, profiling.
std::vector<OptionSpec> bench_options() {
  return {
      {"map", "MAP", "", "TSDF map file (tsdf-mcl build-map)"},
      {"dataset", "DIR", "", "dataset with scans and poses.txt (the true pose places the particles)"},
      {"scan", "K", "1", "index of the scan whose points are used"},
      {"particles", "LIST", "1000,10000,50000,100000", "particle counts, comma-separated"},
      {"points", "M", "1024", "scan points per particle (spread over the whole scan)"},
      {"spread", "local|global", "local", "particles around the true pose (0.5 m, 10 deg) or uniform over the map"},
      {"order", "none|spatial", "none",
       "particle order: as drawn (as the filter keeps them) or sorted into Morton order of position"},
      {"weighing", "whole|subset_first", "whole",
       "cpu, vulkan: every particle on the whole scan, or subset first as the filter weighs large sets "
       "(--subset_points, --subset_share; with --spread global as a global search: --subset_global_points, "
       "--subset_middle_points, --subset_whole_share)"},
      {"subset_points", "K", std::to_string(SubsetFirstOptions{}.points),
       "--weighing subset_first: points of the first pass"},
      {"subset_share", "S", share_text(SubsetFirstOptions{}.share),
       "--weighing subset_first: share of the particles weighed past the first pass"},
      {"subset_global_points", "K", std::to_string(SubsetFirstOptions{}.global_points),
       "--weighing subset_first --spread global: points of the first pass (0 = no middle pass)"},
      {"subset_middle_points", "K", std::to_string(SubsetFirstOptions{}.middle_points),
       "--weighing subset_first --spread global: points of the middle pass (none where K <= --subset_global_points)"},
      {"subset_whole_share", "S", share_text(SubsetFirstOptions{}.whole_share),
       "--weighing subset_first --spread global: share of the particles weighed on the whole scan"},
      {"backend", "LIST", "cpu,vulkan",
       "backends to time: cpu, vulkan, reference (baseline of the reference's CPU design)"},
      {"repetitions", "R", "7", "timed runs per measurement (after warm-up)"},
      {"warmup", "W", "2", "untimed runs first (lavapipe compiles on the first dispatch)"},
      {"sigma_hit", "M", "0.1", "endpoint model sigma (m)"},
      {"likelihood", "product|sum", "product", "log-domain product or the reference's summed form"},
      {"interpolation", "nearest|trilinear", "nearest", "TSDF lookup"},
      {"seed", "N", "1", "random seed for the particle placement"},
      {"map_reads", "texel|storage", "texel", "vulkan: read the map through texel-buffer views or the storage buffers"},
      {"weight_layout", "auto|invocation|subgroup", "auto",
       "vulkan: an invocation or a subgroup per particle in the weighting shader (auto: subgroup on GPUs, "
       "invocation on CPU devices such as lavapipe)"},
      {"profile", "", "",
       "shader profiling run: per-pass GPU time (transfer, weight, reduce) and invocations, the driver's shader "
       "statistics, debug names and labels for RenderDoc / Nsight (extra JSON lines, \"profile\": ...)"},
      {"loop", "SECONDS", "0",
       "after each backend's measurements keep dispatching the largest count's update this long (for an "
       "external profiler)"},
  };
}

// The measurements the options ask for, each option checked.
BenchConfig bench_config(const Options& o) {
  BenchConfig config;
  config.particle_counts.clear();
  for (double v : o.numbers("particles")) {
    if (v < 1 || v != std::floor(v)) throw Error("--particles needs positive integers");
    if (v > static_cast<double>(limits::kMaxParticles)) {
      throw Error("--particles " + std::to_string(static_cast<unsigned long long>(v)) + " is more than the limit of " +
                  std::to_string(limits::kMaxParticles));
    }
    config.particle_counts.push_back(static_cast<std::size_t>(v));
  }
  config.points = o.count("points", limits::kMaxBeams);
  if (config.points == 0) throw Error("--points must be positive");
  config.spread = o.text("spread");
  const std::string order = o.text("order");
  if (order != "spatial" && order != "none") throw Error("--order must be spatial or none");
  config.spatial_order = order == "spatial";
  const std::string weighing = o.text("weighing");
  if (weighing != "whole" && weighing != "subset_first") throw Error("--weighing must be whole or subset_first");
  config.subset_first_weighing = weighing == "subset_first";
  config.subset_first.points = o.count("subset_points", limits::kMaxBeams);
  config.subset_first.share = o.number("subset_share");
  config.subset_first.global_points = o.count("subset_global_points", limits::kMaxBeams);
  config.subset_first.middle_points = o.count("subset_middle_points", limits::kMaxBeams);
  config.subset_first.whole_share = o.number("subset_whole_share");
  config.subset_first.min_particles = 1;  // the bench states the particle counts itself
  config.subset_first.validate();
  config.backends = o.list("backend");
  for (const auto& b : config.backends) {
    if (b != "cpu" && b != "vulkan" && b != "reference") throw Error("unknown backend '" + b + "'");
  }
  config.repetitions = std::max<std::size_t>(1, o.count("repetitions", 1000));
  config.warmup = o.count("warmup", 1000);
  config.seed = static_cast<unsigned>(o.count("seed"));
  config.model.sigma_hit = static_cast<float>(o.number("sigma_hit"));
  const std::string likelihood = o.text("likelihood");
  if (likelihood != "product" && likelihood != "sum") throw Error("--likelihood must be product or sum");
  config.model.likelihood = likelihood == "product" ? Likelihood::kProduct : Likelihood::kSum;
  const std::string interpolation = o.text("interpolation");
  if (interpolation != "nearest" && interpolation != "trilinear")
    throw Error("--interpolation must be nearest or trilinear");
  config.model.interpolation = interpolation == "nearest" ? Interpolation::kNearest : Interpolation::kTrilinear;
  config.model.validate();
  const std::string map_reads = o.text("map_reads");
  if (map_reads != "texel" && map_reads != "storage") throw Error("--map_reads must be texel or storage");
  config.map_texel_views = map_reads == "texel";
  config.weight_layout = parse_weight_layout(o.text("weight_layout"));
  config.profile = o.flag("profile");
  config.loop_seconds = o.number("loop");
  if (!(config.loop_seconds >= 0.0) || config.loop_seconds > 86400.0) throw Error("--loop must lie in [0, 86400] s");

  return config;
}

}  // namespace

int run_bench_command(int argc, char** argv) {
  Options o("bench",
            "tsdf-mcl bench --map MAP --dataset DIR [--scan K] --particles 1000,10000,50000,100000 --points M "
            "[--spread local|global] [--backend cpu,vulkan] [--profile] [--loop SECONDS]",
            bench_options(), argc, argv, 1);
  if (o.help_requested()) {
    std::printf("%s", o.help_text().c_str());
    return 0;
  }
  o.expect_positional(0, "no positional arguments");
  BenchConfig config = bench_config(o);

  const TsdfMap map = load_map(o.text("map"));
  const Dataset dataset = Dataset::open(o.text("dataset"));
  const std::size_t k = o.count("scan");
  if (k >= dataset.size())
    throw Error("--scan " + std::to_string(k) + " but the dataset has " + std::to_string(dataset.size()) + " scans");
  if (!dataset.has_poses()) throw Error("the dataset has no poses.txt (needed to place the particles)");
  config.map_name = o.text("map");
  config.scan_name = dataset.scan_path(k).string();
  run_sensor_update_bench(map, dataset.load_scan(k), dataset.pose(k), config, stdout);
  return 0;
}

}  // namespace tsdf_mcl::bench
