#pragma once
#include <vector>

#include "tsdf_mcl/sensor/endpoint_kernel.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

// The sensor update on the CPU with OpenMP threads over particles: the reference the shaders are tested
// against and the fallback where no Vulkan device exists. Same numbers as the Vulkan evaluator to float
// tolerance; the reduction runs in double over a fixed chunking, so results do not depend on the thread count.
class CpuEvaluator final : public DoubleBufferedEvaluator {
 public:
  // use_simd = false keeps to the scalar path (tests compare the two); otherwise nearest lookups take the AVX2
  // path where the x86-64 CPU has it, the NEON path on aarch64.
  CpuEvaluator(const TsdfMap& map, int threads, bool use_simd = true);

  std::string backend() const override { return "cpu"; }
  std::string device_name() const override;
  void reserve(std::size_t particles, std::size_t points) override;
  void set_points(const std::vector<Eigen::Vector3f>& points) override;
  WeightSummary evaluate(std::size_t particle_count, const EndpointModel& model,
                         const Eigen::Quaternionf& reference_rotation) override;
  void weigh(std::size_t particle_count, const EndpointModel& model) override;
  const UpdateTimings& last_timings() const override { return timings_; }
  // The fast path nearest lookups take: "AVX2", "NEON", or "" for the scalar path.
  const char* simd_path() const;

 private:
  ParticleArrays view(int set) override;
  void rebuild_tables(const EndpointModel& model);
  void weigh_particles(std::size_t n, const EndpointModel& model);  // evaluate() without the reduction

  kernel::MapView map_view_;
  int threads_;
  enum class Simd { kNone, kAvx2, kNeon };
  Simd simd_;
  std::size_t capacity_ = 0;
  std::vector<float> sets_[2];  // 8 arrays of capacity_ floats each: x y z qw qx qy qz log_weight
  std::vector<float> points_;   // x y z x y z ...
  std::size_t point_count_ = 0;
  // Per quantized distance (index q + 32768): log p (product form) or p (sum form), for nearest lookups.
  std::vector<float> table_;
  EndpointModel table_model_;
  bool table_valid_ = false;
  UpdateTimings timings_;
};

}  // namespace tsdf_mcl
