#pragma once
// Subset-first weighing of a large particle set: every particle is weighed on a few of the scan's points first,
// scaled to the whole scan, and only the best-scoring share then on all of them. The rest keep the scaled
// estimate: the same likelihood from fewer points, for particles whose tempered weight is small either way. A
// global belief of 100k particles needs about a third of the point evaluations of weighing everything on the
// whole scan (docs/sensor-update.md, "Fewer evaluations"). Works on any SensorEvaluator: two dispatches, the
// second over the chosen particles gathered into the spare set.
#include <cstdint>
#include <vector>

#include "tsdf_mcl/sensor/endpoint_model.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

struct SubsetFirstOptions {
  std::size_t points = 64;            // the first pass's points, every k-th of the scan (0 = off)
  double share = 0.2;                 // of the particles, weighed on the whole scan
  std::size_t min_particles = 20000;  // smaller sets are weighed on the whole scan: their map reads are cached
  // Also on a discrete GPU (SensorEvaluator::discrete_gpu)? Off: there the whole scan of 100k particles takes
  // 0.7 ms and the two passes, with the host's selection between them, 4.8 ms (NVIDIA H200, docs/sensor-update.md).
  bool on_discrete_gpu = false;
  void validate() const;
};

class SubsetFirstWeighing {
 public:
  explicit SubsetFirstWeighing(const SubsetFirstOptions& options = {});

  // Whether weigh() takes two passes for n particles and this scan and model (only the product likelihood: its
  // log-weight scales with the point count) on `evaluator`.
  bool applies(std::size_t n, std::size_t points, const EndpointModel& model, const SensorEvaluator& evaluator) const;

  // Log-weights of the evaluator's particles 0..n-1 (particles().log_weight), on the scale of the whole scan, and
  // the reduction over all of them (reduce_weights on the host when two passes ran). The spare set is
  // overwritten. `timings`: the passes' GPU and upload times summed, evaluate_ms the whole weighing.
  WeightSummary weigh(SensorEvaluator& evaluator, std::size_t n, const std::vector<Eigen::Vector3f>& points,
                      const EndpointModel& model, const Eigen::Quaternionf& reference, UpdateTimings* timings);

  // The particles the last two-pass weigh() weighed on the whole scan, ascending.
  const std::vector<std::uint32_t>& refined() const { return refined_; }

 private:
  SubsetFirstOptions options_;
  std::vector<std::uint32_t> refined_;
  std::vector<Eigen::Vector3f> subset_;
};

}  // namespace tsdf_mcl
