#include "tsdf_mcl/filter/subset_first.hpp"

#include <algorithm>
#include <cmath>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/stopwatch.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"

namespace tsdf_mcl {
namespace {

std::size_t share_of(double share, std::size_t n) {
  return static_cast<std::size_t>(std::ceil(share * static_cast<double>(n)));
}

// The `count` best-scoring of `from` (ties to the lower index), ascending.
void best_of(const float* log_weight, std::vector<std::uint32_t>& from, std::size_t count) {
  count = std::min(count, from.size());
  std::nth_element(from.begin(), from.begin() + static_cast<std::ptrdiff_t>(count - 1), from.end(),
                   [&](std::uint32_t a, std::uint32_t b) {
                     return log_weight[a] > log_weight[b] || (log_weight[a] == log_weight[b] && a < b);
                   });
  from.resize(count);
  std::sort(from.begin(), from.end());
}

void add_pass(UpdateTimings& sum, const UpdateTimings& pass) {
  sum.transfer_gpu_ms += pass.transfer_gpu_ms;
  sum.weight_gpu_ms += pass.weight_gpu_ms;
  sum.reduce_gpu_ms += pass.reduce_gpu_ms;
  sum.upload_ms += pass.upload_ms;
  sum.weight_invocations += pass.weight_invocations;
  sum.reduce_invocations += pass.reduce_invocations;
}

// The model with its exponent scaled by m / count: a sum over `count` of the scan's m points then estimates the
// whole scan's.
EndpointModel scaled_to(const EndpointModel& model, std::size_t m, std::size_t count) {
  EndpointModel scaled = model;
  scaled.weight_exponent = model.weight_exponent * static_cast<float>(m) / static_cast<float>(count);
  return scaled;
}

}  // namespace

void SubsetFirstOptions::validate() const {
  if (!(share > 0.0 && share <= 1.0)) throw Error("subset_share must lie in (0, 1]");
  if (!(whole_share > 0.0 && whole_share <= 1.0)) throw Error("subset_whole_share must lie in (0, 1]");
}

SubsetFirstWeighing::SubsetFirstWeighing(const SubsetFirstOptions& options) : options_(options) { options_.validate(); }

bool SubsetFirstWeighing::applies(std::size_t n, std::size_t points, const EndpointModel& model,
                                  const SensorEvaluator& evaluator) const {
  return options_.points > 0 && (options_.on_discrete_gpu || !evaluator.discrete_gpu()) &&
         2 * options_.points <= points && n >= std::max<std::size_t>(options_.min_particles, 2) &&
         share_of(options_.share, n) < n && model.likelihood == Likelihood::kProduct;
}

void SubsetFirstWeighing::weigh_chosen(SensorEvaluator& evaluator, const std::vector<std::uint32_t>& chosen,
                                       const std::vector<Eigen::Vector3f>& points, const EndpointModel& model,
                                       UpdateTimings& sum) {
  const ParticleArrays p = evaluator.particles();
  const ParticleArrays spare = evaluator.spare_particles();
  for (std::size_t j = 0; j < chosen.size(); ++j) spare.set(j, p.position(chosen[j]), p.rotation(chosen[j]));
  evaluator.swap_particles();
  try {
    evaluator.set_points(points);
    evaluator.weigh(chosen.size(), model);
  } catch (...) {
    evaluator.swap_particles();
    throw;
  }
  evaluator.swap_particles();
  add_pass(sum, evaluator.last_timings());
}

void SubsetFirstWeighing::assign_passes(std::size_t m, bool middle) {
  // Which pass first weighs each point: 0 the first pass's k, every k-th of the scan (the preprocessed points are in
  // space-filling-curve order, so they spread over it); 1 the middle pass's, spread the same way; 2 the rest.
  const std::size_t k = middle ? options_.global_points : options_.points;
  pass_of_point_.assign(m, 2);
  for (std::size_t j = 0; j < k; ++j) pass_of_point_[j * m / k] = 0;
  if (!middle) return;
  for (std::size_t j = 0; j < options_.middle_points; ++j) {
    std::uint8_t& pass = pass_of_point_[j * m / options_.middle_points];
    pass = std::min<std::uint8_t>(pass, 1);
  }
}

std::size_t SubsetFirstWeighing::points_of_pass(const std::vector<Eigen::Vector3f>& points, std::uint8_t pass) {
  subset_.clear();
  for (std::size_t j = 0; j < points.size(); ++j) {
    if (pass_of_point_[j] == pass) subset_.push_back(points[j]);
  }
  return subset_.size();
}

void SubsetFirstWeighing::weigh_middle_and_rest(SensorEvaluator& evaluator, std::size_t n,
                                                const std::vector<Eigen::Vector3f>& points, const EndpointModel& model,
                                                std::size_t first, UpdateTimings& sum) {
  // Middle pass: the share on the points the first pass lacked, added to the first pass's sum, the whole now scaled by
  // m / (the points of both); then the best of them on the rest of the scan, which completes the sum. Each point is
  // weighed once per particle.
  const std::size_t m = points.size();
  const ParticleArrays p = evaluator.particles();
  const ParticleArrays spare = evaluator.spare_particles();
  const std::size_t both = first + points_of_pass(points, 1);
  weigh_chosen(evaluator, middle_, subset_, scaled_to(model, m, both), sum);
  const double to_both = static_cast<double>(first) / static_cast<double>(both);
  for (std::size_t j = 0; j < middle_.size(); ++j) {
    float& w = p.log_weight[middle_[j]];
    w = static_cast<float>(static_cast<double>(w) * to_both + static_cast<double>(spare.log_weight[j]));
  }
  refined_ = middle_;
  best_of(p.log_weight, refined_, share_of(std::min(options_.whole_share, options_.share), n));
  points_of_pass(points, 2);
  weigh_chosen(evaluator, refined_, subset_, model, sum);
  const double to_whole = static_cast<double>(both) / static_cast<double>(m);
  for (std::size_t j = 0; j < refined_.size(); ++j) {
    float& w = p.log_weight[refined_[j]];
    w = static_cast<float>(static_cast<double>(w) * to_whole + static_cast<double>(spare.log_weight[j]));
  }
}

WeightSummary SubsetFirstWeighing::weigh(SensorEvaluator& evaluator, std::size_t n,
                                         const std::vector<Eigen::Vector3f>& points, const EndpointModel& model,
                                         const Eigen::Quaternionf& reference, UpdateTimings* timings,
                                         bool global_search) {
  refined_.clear();
  middle_.clear();
  if (!applies(n, points.size(), model, evaluator)) {
    evaluator.set_points(points);
    const WeightSummary summary = evaluator.evaluate(n, model, reference);
    if (timings) *timings = evaluator.last_timings();
    return summary;
  }
  const Stopwatch t0;
  const std::size_t m = points.size();
  const bool middle = global_search && options_.global_points > 0 && options_.middle_points > options_.global_points &&
                      2 * options_.middle_points <= m;
  assign_passes(m, middle);
  // First pass: every particle on the k points, the exponent scaled by m / k so the log-weights estimate the whole
  // scan's.
  const std::size_t first = points_of_pass(points, 0);
  evaluator.set_points(subset_);
  evaluator.weigh(n, scaled_to(model, m, first));
  UpdateTimings sum = evaluator.last_timings();
  const ParticleArrays p = evaluator.particles();
  const ParticleArrays spare = evaluator.spare_particles();
  std::vector<std::uint32_t>& best = middle ? middle_ : refined_;
  best.resize(n);
  for (std::size_t i = 0; i < n; ++i) best[i] = static_cast<std::uint32_t>(i);
  best_of(p.log_weight, best, share_of(options_.share, n));

  if (!middle) {
    // Second pass: the best-scoring share on the whole scan.
    weigh_chosen(evaluator, refined_, points, model, sum);
    for (std::size_t j = 0; j < refined_.size(); ++j) p.log_weight[refined_[j]] = spare.log_weight[j];
  } else {
    weigh_middle_and_rest(evaluator, n, points, model, first, sum);
  }
  const WeightSummary summary = reduce_weights(p, n, reference, fit_constants(model, m));
  sum.evaluate_ms = t0.ms();
  if (timings) *timings = sum;
  return summary;
}

}  // namespace tsdf_mcl
