#pragma once
// Sensor-update benchmark: median time of the whole update (weighting + reduction, result on the host) per
// backend and particle count, on a real map and scan. Prints one JSON object per measurement.
#include <cstdio>
#include <string>
#include <vector>

#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/sensor/endpoint_model.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"
#include "tsdf_mcl/filter/subset_first.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::bench {

struct BenchConfig {
  std::vector<std::size_t> particle_counts{1000, 10000, 50000, 100000};
  std::size_t points = 1024;
  std::string spread = "local";  // local: around the scan's true pose; global: uniform over the map box
  // Particles in Morton order of position (particle_order.hpp); false: in the order they were drawn (as the
  // filter keeps them).
  bool spatial_order = false;
  // The cpu and vulkan backends weigh subset first (subset_first.hpp) where it applies, as the filter does;
  // false: every particle on the whole scan. The reference design always weighs the whole scan.
  bool subset_first_weighing = false;
  SubsetFirstOptions subset_first;
  std::vector<std::string> backends{"cpu", "vulkan"};  // also "reference": the baseline of the reference's CPU design
  std::size_t repetitions = 7;
  std::size_t warmup = 2;
  unsigned seed = 1;
  EndpointModel model;
  bool map_texel_views = true;  // vulkan: read the map through texel views (false: the storage buffers)
  WeightLayout weight_layout = WeightLayout::kAuto;  // vulkan: EvaluatorOptions::weight_layout
  std::string map_name;
  std::string scan_name;
  // Shader profiling runs: per-pass GPU time and invocations and the driver's shader statistics as extra JSON lines
  // ("profile": "pass" / "shader"), debug names and labels for captures (EvaluatorOptions::profile).
  bool profile = false;
  // After the measurements of each backend, keep dispatching the largest particle count's update for this long
  // (an external profiler attaches meanwhile), then print one "profile": "loop" line.
  double loop_seconds = 0.0;
};

// Points of the scan spread evenly over the whole scan (every k-th of the finite points), at most `count`.
std::vector<Eigen::Vector3f> spread_points(const PointCloud& scan, std::size_t count);

// Runs every (backend, particle count) and writes one JSON line per measurement to `out`; progress to stderr.
void run_sensor_update_bench(const TsdfMap& map, const PointCloud& scan, const Pose& true_pose,
                             const BenchConfig& config, std::FILE* out);

}  // namespace tsdf_mcl::bench
