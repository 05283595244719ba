#pragma once
// The sensor update: the log-weight of every particle under the endpoint model, plus one reduction over all
// particles. Two backends compute the same numbers: Vulkan compute shaders (endpoint_weight.comp, reduce.comp)
// and a multi-threaded CPU evaluator (the reference and the fallback without a Vulkan device).
//
// Particles live in buffers owned by the evaluator (Vulkan storage buffers, mapped; host memory on the CPU
// backend) as structure-of-arrays; the filter writes them in place. Two sets exist so resampling can write the
// new generation into the spare set and swap, without copies.
#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tsdf_mcl/sensor/endpoint_model.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

// Views into one particle set; each array has `capacity` floats. Pose = world_T_sensor as a position and a
// unit quaternion.
struct ParticleArrays {
  float* x = nullptr;
  float* y = nullptr;
  float* z = nullptr;
  float* qw = nullptr;
  float* qx = nullptr;
  float* qy = nullptr;
  float* qz = nullptr;
  float* log_weight = nullptr;  // written by evaluate()
  std::size_t capacity = 0;

  // Views into one block of 8 * capacity floats laid out x.. y.. z.. qw.. qx.. qy.. qz.. log_weight..
  static ParticleArrays over(float* base, std::size_t capacity) {
    return {base,
            base + capacity,
            base + 2 * capacity,
            base + 3 * capacity,
            base + 4 * capacity,
            base + 5 * capacity,
            base + 6 * capacity,
            base + 7 * capacity,
            capacity};
  }

  Eigen::Vector3f position(std::size_t i) const { return {x[i], y[i], z[i]}; }
  Eigen::Quaternionf rotation(std::size_t i) const { return {qw[i], qx[i], qy[i], qz[i]}; }
  void set(std::size_t i, const Eigen::Vector3f& p, const Eigen::Quaternionf& q) const {
    x[i] = p.x();
    y[i] = p.y();
    z[i] = p.z();
    qw[i] = q.w();
    qx[i] = q.x();
    qy[i] = q.y();
    qz[i] = q.z();
  }
};

// Result of the reduction over particles 0..n-1 (weights w_i = exp(log_weight_i - max_log_weight)).
struct WeightSummary {
  float max_log_weight = 0.0f;
  double weight_sum = 0.0;                                  // Σ w
  Eigen::Vector3d mean_position = Eigen::Vector3d::Zero();  // Σ w p / Σ w
  // Σ w q (w, x, y, z) with each q's sign flipped to the hemisphere of the reference quaternion; its
  // normalized direction is the weighted rotation mean.
  Eigen::Vector4d quaternion_sum = Eigen::Vector4d::Zero();
  // Σ over particles of the per-point mean likelihood (geometric mean for Likelihood::kProduct, arithmetic
  // for kSum, undoing weight_exponent); divided by n it is a fit measure independent of particle and point
  // counts (what recovery's w_slow / w_fast follow).
  double fit_sum = 0.0;
};

// GPU time per pass from timestamp queries (NaN where unavailable), and host wall time of the update.
struct UpdateTimings {
  double transfer_gpu_ms = std::nan("");  // the points' copy from a staging buffer (discrete GPUs; 0 without one)
  double weight_gpu_ms = std::nan("");
  double reduce_gpu_ms = std::nan("");
  double upload_ms = 0.0;    // points into their buffer
  double evaluate_ms = 0.0;  // submit to results visible on the host (weighting + reduction)
  // Compute-shader invocations per pass from pipeline-statistics queries (EvaluatorOptions::profile, where the
  // device has them); 0 otherwise.
  std::uint64_t weight_invocations = 0;
  std::uint64_t reduce_invocations = 0;
};

// The driver's statistics of one compiled shader (VK_KHR_pipeline_executable_properties: registers, spills,
// instruction counts, named as the driver names them).
struct ShaderStatistics {
  std::string pipeline;    // "endpoint_weight", "reduce"
  std::string executable;  // the driver's name of the compiled stage
  std::vector<std::pair<std::string, std::string>> values;
};

class SensorEvaluator {
 public:
  virtual ~SensorEvaluator() = default;
  virtual std::string backend() const = 0;  // "vulkan" or "cpu"
  virtual std::string device_name() const = 0;
  // How the map is read: "texel" or "storage" (Vulkan; texel views fall back to storage reads where the map
  // exceeds the device's texel-buffer limit), "" where the question does not apply (CPU).
  virtual std::string map_reads() const { return ""; }
  // Vulkan: "invocation" or "subgroup" per particle (EvaluatorOptions::weight_layout); empty elsewhere.
  virtual std::string weight_layout() const { return ""; }
  // A discrete GPU: its own memory, thousands of lanes. Weighing on fewer points first does not pay there
  // (SubsetFirstOptions::on_discrete_gpu).
  virtual bool discrete_gpu() const { return false; }

  // Grows buffers if needed (never shrinks); invalidates previously returned ParticleArrays when it grows.
  virtual void reserve(std::size_t particles, std::size_t points) = 0;
  virtual ParticleArrays particles() = 0;        // the active set
  virtual ParticleArrays spare_particles() = 0;  // the other set
  virtual void swap_particles() = 0;

  // Scan points in the sensor frame; must be finite.
  virtual void set_points(const std::vector<Eigen::Vector3f>& points) = 0;
  // Weights particles 0..n-1 of the active set against the current points; reduces.
  virtual WeightSummary evaluate(std::size_t particle_count, const EndpointModel& model,
                                 const Eigen::Quaternionf& reference_rotation) = 0;
  // The log-weights of evaluate() without its reduction, for callers that reduce on the host after combining
  // passes (SubsetFirstWeighing). The default runs evaluate().
  virtual void weigh(std::size_t particle_count, const EndpointModel& model) {
    evaluate(particle_count, model, Eigen::Quaternionf::Identity());
  }
  virtual const UpdateTimings& last_timings() const = 0;
  // With EvaluatorOptions::profile on a driver that reports them; empty otherwise.
  virtual std::vector<ShaderStatistics> shader_statistics() const { return {}; }
};

// An evaluator that holds its two particle sets itself, as both backends do: the active set and the spare one, which
// swap_particles() exchanges. A backend gives view(set) of set 0 or 1.
class DoubleBufferedEvaluator : public SensorEvaluator {
 public:
  ParticleArrays particles() final { return view(active_); }
  ParticleArrays spare_particles() final { return view(1 - active_); }
  void swap_particles() final { active_ = 1 - active_; }

 protected:
  virtual ParticleArrays view(int set) = 0;
  int active_set() const { return active_; }

 private:
  int active_ = 0;
};

enum class Backend { kAuto, kVulkan, kCpu };
Backend parse_backend(const std::string& name);  // "auto" | "vulkan" | "cpu"; throws Error otherwise

enum class WeightLayout { kAuto, kInvocationPerParticle, kSubgroupPerParticle };
// "auto" | "invocation" | "subgroup"; throws Error otherwise.
WeightLayout parse_weight_layout(const std::string& name);

struct EvaluatorOptions {
  Backend backend = Backend::kAuto;
  // Vulkan: enable VK_LAYER_KHRONOS_validation; every message goes to on_validation_message
  // (default: printed to stderr).
  bool validation = false;
  std::function<void(const std::string&)> on_validation_message;
  int device_index = -1;  // -1: prefer a discrete/integrated GPU, then any device (lavapipe)
  int cpu_threads = 0;    // 0: all hardware threads
  // Vulkan: reduce with subgroup arithmetic where the device has it; false forces the shared-memory tree
  // (both variants are tested on every device).
  bool subgroup_reduction = true;
  // Vulkan: read scan points through a uniform-buffer view of their storage buffer when they fit (up to 4096);
  // false keeps to the storage-buffer binding (both paths are tested).
  bool uniform_points = true;
  // Vulkan: read the map's storage buffers through uniform texel-buffer views of the same memory (lavapipe
  // gathers texel fetches in SIMD but loops over the lanes for storage-buffer loads); false reads the storage
  // buffers directly (both paths are tested).
  bool map_texel_views = true;
  // Vulkan: how endpoint_weight.comp lays particles over invocations. kAuto: a subgroup per particle (its lanes
  // strided over the points) on GPUs with subgroup arithmetic, an invocation per particle on CPU devices
  // (lavapipe), whose SIMD lanes are the invocations. Both layouts are tested on every device.
  WeightLayout weight_layout = WeightLayout::kAuto;
  // Vulkan: the largest map binding in bytes (0: the device's maxStorageBufferRange). Larger block pools are split
  // into up to four chunks; tests set a small value to exercise the split on a small map.
  std::uint64_t max_map_binding_bytes = 0;
  // Vulkan, for shader profiling runs: pipeline-statistics queries per pass (UpdateTimings), the driver's shader
  // statistics (shader_statistics()), and VK_EXT_debug_utils names on every object and labels on every pass so a
  // RenderDoc / Nsight capture reads cleanly. Each where the device offers it.
  bool profile = false;
};

// One particle's log-weight from the kernel's likelihood (tsdf_mcl/sensor/endpoint_kernel.hpp), accumulated in double:
// what the tests hold both backends against.
double reference_log_weight(const TsdfMap& map, const EndpointModel& model, const Eigen::Vector3f& position,
                            const Eigen::Quaternionf& rotation, const std::vector<Eigen::Vector3f>& points);
// Each point's log-likelihood log p (the model's weight_exponent not applied) at one pose, into `out`
// (resized to points.size()).
void point_log_likelihoods(const TsdfMap& map, const EndpointModel& model, const Eigen::Vector3f& position,
                           const Eigen::Quaternionf& rotation, const std::vector<Eigen::Vector3f>& points,
                           std::vector<double>& out);

}  // namespace tsdf_mcl
