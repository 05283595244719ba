#include "sensor_update_bench.hpp"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>

#include "reference_cpu_baseline.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/backends/make_evaluator.hpp"
#include "particle_order.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"
#include "tsdf_mcl/filter/subset_first.hpp"

namespace tsdf_mcl::bench {
namespace {

using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

void place_particles(const ParticleArrays& p, std::size_t n, const TsdfMap& map, const Pose& true_pose,
                     const std::string& spread, std::mt19937& rng) {
  std::normal_distribution<float> g(0.0f, 1.0f);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const Eigen::Vector3f t = true_pose.translation().cast<float>();
  const Eigen::Quaternionf q(true_pose.linear().cast<float>());
  const Eigen::Vector3f lo = map.world_min(), hi = map.world_max();
  for (std::size_t i = 0; i < n; ++i) {
    if (spread == "local") {
      // 0.5 m and 10 degrees: the spread of a filter that is tracking but not yet converged.
      const Eigen::Vector3f dp(0.5f * g(rng), 0.5f * g(rng), 0.1f * g(rng));
      const Eigen::Vector3f axis_angle =
          Eigen::Vector3f(g(rng), g(rng), g(rng)) * (10.0f * 3.14159265f / 180.0f / 1.7320508f);
      const Eigen::Quaternionf dq(Eigen::AngleAxisf(axis_angle.norm(), axis_angle.normalized()));
      p.set(i, t + dp, (q * dq).normalized());
    } else {
      const Eigen::Vector3f pos = lo + (hi - lo).cwiseProduct(Eigen::Vector3f(u(rng), u(rng), u(rng)));
      p.set(i, pos, Eigen::Quaternionf::UnitRandom());
    }
  }
}

}  // namespace

std::vector<Eigen::Vector3f> spread_points(const PointCloud& scan, std::size_t count) {
  std::vector<Eigen::Vector3f> finite;
  finite.reserve(scan.size());
  for (const auto& p : scan.points) {
    if (p.allFinite() && p.norm() > 0.1f) finite.push_back(p);
  }
  if (finite.empty()) throw Error("the scan has no finite points");
  if (finite.size() <= count) return finite;
  std::vector<Eigen::Vector3f> out(count);
  for (std::size_t i = 0; i < count; ++i) out[i] = finite[i * finite.size() / count];
  return out;
}

namespace {

// The backend under test: an evaluator, or the reference design's CPU loop over particles of its own.
struct BackendUnderTest {
  std::unique_ptr<SensorEvaluator> evaluator;
  std::vector<float> reference_storage;
  ParticleArrays reference_particles;
  std::string device;

  BackendUnderTest(const std::string& backend, const TsdfMap& map, const BenchConfig& config,
                   const std::vector<Eigen::Vector3f>& points, std::size_t max_particles) {
    if (backend == "reference") {
      reference_storage.assign(8 * max_particles, 0.0f);
      reference_particles = ParticleArrays::over(reference_storage.data(), max_particles);
      device = "CPU";
      return;
    }
    EvaluatorOptions options;
    options.backend = parse_backend(backend);
    options.map_texel_views = config.map_texel_views;
    options.weight_layout = config.weight_layout;
    options.profile = config.profile;
    evaluator = make_evaluator(map, options);
    evaluator->reserve(max_particles, points.size());
    evaluator->set_points(points);
    device = evaluator->device_name();
  }
  bool profiled(const BenchConfig& config) const {
    return config.profile && evaluator && evaluator->backend() == "vulkan";
  }
};

// One sensor update as the filter runs it: the whole scan for every particle, or subset first.
struct SensorUpdate {
  const BenchConfig& config;
  const std::vector<Eigen::Vector3f>& points;
  SubsetFirstWeighing weighing;

  UpdateTimings operator()(SensorEvaluator& e, std::size_t n, const Eigen::Quaternionf& reference) {
    if (!config.subset_first_weighing) {
      e.evaluate(n, config.model, reference);
      return e.last_timings();
    }
    UpdateTimings t;
    // Particles uniform over the map box are a global search; those around the true pose are one place.
    weighing.weigh(e, n, points, config.model, reference, &t, config.spread == "global");
    return t;
  }
};

// The timed repetitions of one particle count (host time; GPU time per pass where the backend reports it).
struct Samples {
  std::vector<double> host_ms;
  std::vector<double> gpu_ms;
  std::vector<double> pass_ms[3];  // transfer, weight, reduce (profile)
  std::uint64_t invocations[2] = {0, 0};
};

Samples measure(const TsdfMap& map, const BenchConfig& config, const std::vector<Eigen::Vector3f>& points,
                BackendUnderTest& b, SensorUpdate& update, const ParticleArrays& particles, std::size_t n) {
  Samples s;
  for (std::size_t r = 0; r < config.warmup + config.repetitions; ++r) {
    const auto t0 = Clock::now();
    UpdateTimings t;
    if (b.evaluator) {
      t = update(*b.evaluator, n, particles.rotation(0));
    } else {
      reference_cpu_weights(map, config.model, particles, n, points);
    }
    const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    if (r < config.warmup) continue;
    s.host_ms.push_back(ms);
    if (b.evaluator && std::isfinite(t.weight_gpu_ms)) {
      s.gpu_ms.push_back(t.weight_gpu_ms + t.reduce_gpu_ms);
      s.pass_ms[0].push_back(t.transfer_gpu_ms);
      s.pass_ms[1].push_back(t.weight_gpu_ms);
      s.pass_ms[2].push_back(t.reduce_gpu_ms);
    }
    if (b.evaluator) {
      s.invocations[0] = t.weight_invocations;
      s.invocations[1] = t.reduce_invocations;
    }
  }
  return s;
}

// One particle count's JSON line, and with --profile a line per GPU pass.
void write_measurement(const std::string& backend, const BackendUnderTest& b, const BenchConfig& config,
                       const std::vector<Eigen::Vector3f>& points, const SensorUpdate& update, std::size_t n,
                       const Samples& s, std::FILE* out) {
  const SensorEvaluator* evaluator = b.evaluator.get();
  const double med = median(s.host_ms);
  nlohmann::json line = {
      {"backend", backend},
      {"device", b.device},
      {"particles", n},
      {"points", points.size()},
      {"spread", config.spread},
      {"order", config.spatial_order ? "spatial" : "none"},
      {"weighing", !evaluator || !config.subset_first_weighing                           ? "whole"
                   : update.weighing.applies(n, points.size(), config.model, *evaluator) ? "subset_first"
                                                                                         : "whole"},
      {"median_ms", med},
      {"min_ms", *std::min_element(s.host_ms.begin(), s.host_ms.end())},
      {"gpu_ms", s.gpu_ms.empty() ? nlohmann::json(nullptr) : nlohmann::json(median(s.gpu_ms))},
      {"evals_per_s", static_cast<double>(n) * static_cast<double>(points.size()) / (med * 1e-3)},
      {"repetitions", config.repetitions},
      {"likelihood", config.model.likelihood == Likelihood::kProduct ? "product" : "sum"},
      {"interpolation", config.model.interpolation == Interpolation::kNearest ? "nearest" : "trilinear"},
      {"map_reads",
       !evaluator || evaluator->map_reads().empty() ? nlohmann::json(nullptr) : nlohmann::json(evaluator->map_reads())},
      {"weight_layout", !evaluator || evaluator->weight_layout().empty() ? nlohmann::json(nullptr)
                                                                         : nlohmann::json(evaluator->weight_layout())},
      {"map", config.map_name},
      {"scan", config.scan_name},
  };
  std::fprintf(out, "%s\n", line.dump().c_str());
  if (b.profiled(config)) {
    const char* names[3] = {"transfer", "weight", "reduce"};
    for (int k = 0; k < 3; ++k) {
      nlohmann::json pass = {{"profile", "pass"}, {"backend", backend},      {"device", b.device},
                             {"particles", n},    {"points", points.size()}, {"spread", config.spread},
                             {"pass", names[k]}};
      pass["gpu_ms"] = s.pass_ms[k].empty() ? nlohmann::json(nullptr) : nlohmann::json(median(s.pass_ms[k]));
      pass["invocations"] =
          k == 0 || s.invocations[k - 1] == 0 ? nlohmann::json(nullptr) : nlohmann::json(s.invocations[k - 1]);
      std::fprintf(out, "%s\n", pass.dump().c_str());
    }
  }
  std::fflush(out);
  std::fprintf(stderr, "bench: %s %zu particles x %zu points: %.1f ms\n", backend.c_str(), n, points.size(), med);
}

// --profile: the driver's statistics of each shader, or a line saying why there are none.
void write_shader_statistics(const std::string& backend, const BackendUnderTest& b, std::FILE* out) {
  const std::vector<ShaderStatistics> shaders = b.evaluator->shader_statistics();
  for (const ShaderStatistics& sh : shaders) {
    nlohmann::json stats = nlohmann::json::object();
    for (const auto& [name, value] : sh.values) stats[name] = value;
    nlohmann::json row = {{"profile", "shader"},     {"backend", backend},          {"device", b.device},
                          {"pipeline", sh.pipeline}, {"executable", sh.executable}, {"statistics", stats}};
    std::fprintf(out, "%s\n", row.dump().c_str());
  }
  if (shaders.empty()) {
    nlohmann::json row = {{"profile", "shader"},
                          {"backend", backend},
                          {"device", b.device},
                          {"statistics", nullptr},
                          {"note", backend == "vulkan" ? "the driver does not report shader statistics "
                                                         "(VK_KHR_pipeline_executable_properties)"
                                                       : "no shaders: CPU backend"}};
    std::fprintf(out, "%s\n", row.dump().c_str());
  }
}

// --loop, for an external profiler (perf, Nsight, RenderDoc): the largest count's update, over and over.
void loop_for_profiler(const std::string& backend, BackendUnderTest& b, SensorUpdate& update, const TsdfMap& map,
                       const Pose& true_pose, const BenchConfig& config, std::size_t point_count,
                       std::size_t max_particles, std::FILE* out) {
  const std::size_t n = max_particles;
  std::mt19937 rng(config.seed);
  const ParticleArrays particles = b.evaluator->particles();
  place_particles(particles, n, map, true_pose, config.spread, rng);
  std::fprintf(stderr, "bench: %s: dispatching %zu particles x %zu points for %.0f s (pid %d)\n", backend.c_str(), n,
               point_count, config.loop_seconds, static_cast<int>(getpid()));
  const auto t0 = Clock::now();
  std::size_t updates = 0;
  double elapsed = 0.0;
  while (elapsed < config.loop_seconds) {
    update(*b.evaluator, n, particles.rotation(0));
    ++updates;
    elapsed = std::chrono::duration<double>(Clock::now() - t0).count();
  }
  nlohmann::json row = {{"profile", "loop"},     {"backend", backend},
                        {"device", b.device},    {"particles", n},
                        {"points", point_count}, {"seconds", elapsed},
                        {"updates", updates},    {"mean_ms", 1e3 * elapsed / static_cast<double>(updates)}};
  std::fprintf(out, "%s\n", row.dump().c_str());
  std::fflush(out);
}

}  // namespace

void run_sensor_update_bench(const TsdfMap& map, const PointCloud& scan, const Pose& true_pose,
                             const BenchConfig& config, std::FILE* out) {
  if (config.spread != "local" && config.spread != "global") throw Error("--spread must be local or global");
  const std::vector<Eigen::Vector3f> points = spread_points(scan, config.points);
  const std::size_t max_particles = *std::max_element(config.particle_counts.begin(), config.particle_counts.end());
  for (const std::string& backend : config.backends) {
    BackendUnderTest b(backend, map, config, points, max_particles);
    // --weighing subset_first measures the two passes on every device, a discrete GPU's included.
    SubsetFirstOptions subset_first = config.subset_first;
    subset_first.on_discrete_gpu = true;
    SensorUpdate update{config, points, SubsetFirstWeighing(subset_first)};
    for (std::size_t n : config.particle_counts) {
      std::mt19937 rng(config.seed);
      const ParticleArrays particles = b.evaluator ? b.evaluator->particles() : b.reference_particles;
      place_particles(particles, n, map, true_pose, config.spread, rng);
      // Every backend gets the same particles in the same order (the reference design's included).
      if (config.spatial_order) sort_spatially(particles, n);
      const Samples s = measure(map, config, points, b, update, particles, n);
      write_measurement(backend, b, config, points, update, n, s, out);
    }
    if (b.profiled(config)) write_shader_statistics(backend, b, out);
    if (config.loop_seconds > 0.0 && b.evaluator)
      loop_for_profiler(backend, b, update, map, true_pose, config, points.size(), max_particles, out);
  }
}

}  // namespace tsdf_mcl::bench
