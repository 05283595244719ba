#include "tsdf_mcl/filter/subset_first.hpp"

#include <algorithm>
#include <cmath>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/stopwatch.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"

namespace tsdf_mcl {
namespace {

std::size_t refined_count(double share, std::size_t n) {
  return static_cast<std::size_t>(std::ceil(share * static_cast<double>(n)));
}

}  // namespace

void SubsetFirstOptions::validate() const {
  if (!(share > 0.0 && share <= 1.0)) throw Error("subset_share must lie in (0, 1]");
}

SubsetFirstWeighing::SubsetFirstWeighing(const SubsetFirstOptions& options) : options_(options) { options_.validate(); }

bool SubsetFirstWeighing::applies(std::size_t n, std::size_t points, const EndpointModel& model,
                                  const SensorEvaluator& evaluator) const {
  return options_.points > 0 && (options_.on_discrete_gpu || !evaluator.discrete_gpu()) &&
         2 * options_.points <= points && n >= std::max<std::size_t>(options_.min_particles, 2) &&
         refined_count(options_.share, n) < n && model.likelihood == Likelihood::kProduct;
}

WeightSummary SubsetFirstWeighing::weigh(SensorEvaluator& evaluator, std::size_t n,
                                         const std::vector<Eigen::Vector3f>& points, const EndpointModel& model,
                                         const Eigen::Quaternionf& reference, UpdateTimings* timings) {
  refined_.clear();
  if (!applies(n, points.size(), model, evaluator)) {
    evaluator.set_points(points);
    const WeightSummary summary = evaluator.evaluate(n, model, reference);
    if (timings) *timings = evaluator.last_timings();
    return summary;
  }
  const Stopwatch t0;
  // First pass: k points spread over the scan (the preprocessed points are in space-filling-curve order), the
  // exponent scaled by m / k so the log-weights estimate the whole scan's.
  const std::size_t k = options_.points;
  subset_.clear();
  for (std::size_t j = 0; j < k; ++j) subset_.push_back(points[j * points.size() / k]);
  EndpointModel scaled = model;
  scaled.weight_exponent = model.weight_exponent * static_cast<float>(points.size()) / static_cast<float>(k);
  evaluator.set_points(subset_);
  evaluator.evaluate(n, scaled, reference);
  UpdateTimings sum = evaluator.last_timings();

  // Second pass: the best-scoring share, gathered into the spare set in particle order (their map reads keep
  // the set's locality), weighed on the whole scan and scattered back. Ties go to the lower index.
  const ParticleArrays p = evaluator.particles();
  const std::size_t refined = refined_count(options_.share, n);
  refined_.resize(n);
  for (std::size_t i = 0; i < n; ++i) refined_[i] = static_cast<std::uint32_t>(i);
  std::nth_element(refined_.begin(), refined_.begin() + static_cast<std::ptrdiff_t>(refined - 1), refined_.end(),
                   [&](std::uint32_t a, std::uint32_t b) {
                     return p.log_weight[a] > p.log_weight[b] || (p.log_weight[a] == p.log_weight[b] && a < b);
                   });
  refined_.resize(refined);
  std::sort(refined_.begin(), refined_.end());
  const ParticleArrays spare = evaluator.spare_particles();
  for (std::size_t j = 0; j < refined; ++j) spare.set(j, p.position(refined_[j]), p.rotation(refined_[j]));
  evaluator.swap_particles();
  try {
    evaluator.set_points(points);
    evaluator.evaluate(refined, model, reference);
  } catch (...) {
    evaluator.swap_particles();
    throw;
  }
  evaluator.swap_particles();
  for (std::size_t j = 0; j < refined; ++j) p.log_weight[refined_[j]] = spare.log_weight[j];

  const UpdateTimings& second = evaluator.last_timings();
  sum.transfer_gpu_ms += second.transfer_gpu_ms;
  sum.weight_gpu_ms += second.weight_gpu_ms;
  sum.reduce_gpu_ms += second.reduce_gpu_ms;
  sum.upload_ms += second.upload_ms;
  sum.weight_invocations += second.weight_invocations;
  sum.reduce_invocations += second.reduce_invocations;
  const WeightSummary summary = reduce_weights(p, n, reference, fit_constants(model, points.size()));
  sum.evaluate_ms = t0.ms();
  if (timings) *timings = sum;
  return summary;
}

}  // namespace tsdf_mcl
