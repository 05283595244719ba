#include "tsdf_mcl/cpu/cpu_evaluator.hpp"

#include <omp.h>

#include <algorithm>
#include <thread>

#include "tsdf_mcl/core/stopwatch.hpp"
#include "tsdf_mcl/cpu/endpoint_avx2.hpp"
#include "tsdf_mcl/cpu/endpoint_neon.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {}  // namespace

CpuEvaluator::CpuEvaluator(const TsdfMap& map, int threads, bool use_simd)
    : map_view_(map),
      threads_(threads > 0 ? threads : std::max(1, static_cast<int>(std::thread::hardware_concurrency()))),
      simd_(!use_simd                  ? Simd::kNone
            : kernel::avx2_available() ? Simd::kAvx2
            : kernel::neon_available() ? Simd::kNeon
                                       : Simd::kNone) {
  if (map.empty()) throw Error("the map is empty");
}

const char* CpuEvaluator::simd_path() const {
  return simd_ == Simd::kAvx2 ? "AVX2" : simd_ == Simd::kNeon ? "NEON" : "";
}

std::string CpuEvaluator::device_name() const {
  const std::string simd = simd_path();
  return "CPU (" + std::to_string(threads_) + " threads" + (simd.empty() ? "" : ", " + simd) + ")";
}

void CpuEvaluator::reserve(std::size_t particles, std::size_t points) {
  if (particles > capacity_) {
    const std::size_t capacity = std::max(particles, capacity_ + capacity_ / 2);
    for (auto& set : sets_) {
      std::vector<float> grown(8 * capacity, 0.0f);
      for (std::size_t a = 0; a < 8 && capacity_ > 0; ++a) {
        std::copy_n(set.begin() + static_cast<std::ptrdiff_t>(a * capacity_), capacity_,
                    grown.begin() + static_cast<std::ptrdiff_t>(a * capacity));
      }
      set.swap(grown);
    }
    capacity_ = capacity;
  }
  points_.reserve(3 * points);
}

ParticleArrays CpuEvaluator::view(int set) { return ParticleArrays::over(sets_[set].data(), capacity_); }

void CpuEvaluator::set_points(const std::vector<Eigen::Vector3f>& points) {
  const Stopwatch t0;
  points_.resize(3 * points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) throw Error("scan point " + std::to_string(i) + " is not finite");
    points_[3 * i] = points[i].x();
    points_[3 * i + 1] = points[i].y();
    points_[3 * i + 2] = points[i].z();
  }
  point_count_ = points.size();
  timings_.upload_ms = t0.ms();
}

void CpuEvaluator::rebuild_tables(const EndpointModel& model) {
  if (table_valid_ && kernel::same_table(model, table_model_)) return;
  kernel::likelihood_table(model, map_view_.quant_step, table_);
  table_model_ = model;
  table_valid_ = true;
}

WeightSummary CpuEvaluator::evaluate(std::size_t n, const EndpointModel& model,
                                     const Eigen::Quaternionf& reference_rotation) {
  const Stopwatch t0;
  weigh_particles(n, model);
  const WeightSummary summary = reduce_weights(particles(), n, reference_rotation, fit_constants(model, point_count_));
  timings_.evaluate_ms = t0.ms();
  return summary;
}

void CpuEvaluator::weigh(std::size_t n, const EndpointModel& model) {
  const Stopwatch t0;
  weigh_particles(n, model);
  timings_.evaluate_ms = t0.ms();
}

void CpuEvaluator::weigh_particles(std::size_t n, const EndpointModel& model) {
  model.validate();
  if (n > capacity_) throw Error("evaluate: particle count exceeds the reserved capacity");
  if (point_count_ == 0) throw Error("evaluate: no scan points set");
  rebuild_tables(model);
  const ParticleArrays p = particles();
  const kernel::ModelConstants k(model);
  const float* pts = points_.data();
  const auto m = static_cast<std::ptrdiff_t>(point_count_);
  const float* table = table_.data() + 32768;
  const kernel::MapView& map = map_view_;
  const bool product = model.likelihood == Likelihood::kProduct;
  const bool trilinear = model.interpolation == Interpolation::kTrilinear;
  const float exponent = model.weight_exponent;

  if (!trilinear && simd_ != Simd::kNone) {
    // Groups of 8 (AVX2) or 4 (NEON) particles; chunks of 64 keep the threads' shares even.
    constexpr std::size_t kChunk = 64;
    const auto chunks = static_cast<std::ptrdiff_t>((n + kChunk - 1) / kChunk);
#pragma omp parallel for num_threads(threads_) schedule(static)
    for (std::ptrdiff_t c = 0; c < chunks; ++c) {
      const std::size_t begin = static_cast<std::size_t>(c) * kChunk;
      const std::size_t end = std::min(n, begin + kChunk);
      if (simd_ == Simd::kAvx2) {
        kernel::accumulate_nearest_avx2(map, table_.data(), p, begin, end, pts, point_count_, p.log_weight);
      } else {
        kernel::accumulate_nearest_neon(map, table_.data(), p, begin, end, pts, point_count_, p.log_weight);
      }
      for (std::size_t i = begin; i < end; ++i) {
        p.log_weight[i] = exponent * (product ? p.log_weight[i] : std::log(p.log_weight[i]));
      }
    }
    return;
  }

#pragma omp parallel for num_threads(threads_) schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    float r[9];
    kernel::rotation_matrix(p.qw[i], p.qx[i], p.qy[i], p.qz[i], r);
    const float t[3] = {p.x[i], p.y[i], p.z[i]};
    float acc = 0.0f;
    for (std::ptrdiff_t j = 0; j < m; ++j) {
      float g[3];
      kernel::to_grid(r, t, map.inv_voxel, pts[3 * j], pts[3 * j + 1], pts[3 * j + 2], g);
      float v;
      if (!trilinear) {
        v = table[kernel::sample_nearest(map, g)];
      } else {
        float d;
        const bool known = kernel::sample_trilinear(map, g, &d);
        v = product ? (known ? std::log(k.likelihood(d)) : k.log_p_unknown) : (known ? k.likelihood(d) : k.p_unknown);
      }
      acc += v;
    }
    p.log_weight[i] = exponent * (product ? acc : std::log(acc));
  }
}

}  // namespace tsdf_mcl
