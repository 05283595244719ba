// ParticleFilter's resampling: how many particles join from the proposal (recovery, challengers, a restored
// track) and the next generation drawn per hypothesis (particle_filter.hpp).
#include "tsdf_mcl/filter/particle_filter.hpp"

#include <algorithm>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <string>

#include "tsdf_mcl/core/stopwatch.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/hypothesis_weighting.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"
#include "tsdf_mcl/filter/scan_fit.hpp"

namespace tsdf_mcl {

ParticleFilter::Injection ParticleFilter::plan_injection(double time, const FilterStep& step) const {
  Injection in;
  const std::size_t max = params_.kld.max_particles;
  // Particles put tightly around one place (a restored track, a proven look-alike): as many as a kept hypothesis.
  const std::size_t around_count =
      std::min(max, std::max<std::size_t>(params_.hypothesis_min_particles, params_.kld.min_particles));
  if (step.random_share > 0.0) {
    // Recovery. After an implausible fit the track is wrong and the search starts over: screened on this scan
    // like a global search. After a dip of the relative fit (a correct track shows them now and then) drawn as
    // they come: only a lost track lets such guesses win.
    in.count = std::min(max, static_cast<std::size_t>(std::lround(step.random_share * static_cast<double>(max))));
    in.candidates =
        step.implausible ? std::max(in.count, std::min(10 * in.count, params_.global_search.candidates)) : in.count;
    in.share = step.random_share;
  } else if (restore_pending_ && keeper_.active()) {
    // A disproven challenger took the belief off the track: half of it goes back there, tightly around it.
    in.count = around_count;
    in.candidates = in.count;
    in.share = 0.5;
    in.around = keeper_.pose();
  } else if (look_alike_to_restore_) {
    // A look-alike of which the belief holds too little (proven better, or kept before the track first converged): as
    // many particles, with the share its evidence gives it (remember_look_alikes).
    in.count = around_count;
    in.candidates = in.count;
    in.share = look_alike_to_restore_->share;
    in.around = look_alike_to_restore_->place;
    in.look_alike = true;
  } else if (params_.challenger_candidates > 0 && ever_concentrated_ &&
             time - last_challenge_time_ >= params_.challenger_interval) {
    in.candidates = params_.challenger_candidates;
    in.count = std::max<std::size_t>(1, in.candidates / 200);
    // A tenth of a competitor's share: one scan that a challenger explains clearly better makes it one.
    in.share = params_.convergence.competitor_min_weight / 10.0;
  }
  return in;
}

ParticleFilter::GroupCounts ParticleFilter::count_groups(std::size_t n, std::size_t budget, std::size_t room) {
  // Particle counts per group: each hypothesis heavy enough to keep at least hypothesis_min_particles, the rest
  // of the budget by share. Lighter hypotheses join the rest and take their chances.
  const std::size_t groups = group_share_.size();
  const std::size_t rest = groups - 1;
  GroupCounts out;
  std::vector<std::size_t>& counts = out.counts;
  counts.assign(groups, 0);
  std::vector<bool> kept_group(groups, false);
  out.rest_share = group_share_[rest];
  for (std::size_t g = 0; g < rest; ++g) {
    if (group_share_[g] >= params_.hypothesis_min_weight) {
      kept_group[g] = true;
      counts[g] = std::max(params_.hypothesis_min_particles,
                           static_cast<std::size_t>(std::lround(group_share_[g] * static_cast<double>(budget))));
    } else {
      out.rest_share += group_share_[g];
    }
  }
  // Every credible hypothesis (one that could compete, convergence.hpp) gets as many particles as the largest:
  // with fewer, its mean sits a little off, its fit at its refined pose comes out a little worse, and the
  // evidence drifts towards whichever look-alike happened to hold more particles.
  // (Only the kept ones: with hypothesis_min_weight above competitor_min_weight a credible hypothesis may have joined
  // the rest, its group left without particles.)
  const auto credible = [&](std::size_t g) {
    return kept_group[g] && group_share_[g] >= params_.convergence.competitor_min_weight;
  };
  std::size_t credible_count = 0;
  for (std::size_t g = 0; g < rest; ++g) {
    if (credible(g)) credible_count = std::max(credible_count, counts[g]);
  }
  for (std::size_t g = 0; g < rest; ++g) {
    if (credible(g)) counts[g] = credible_count;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!kept_group[static_cast<std::size_t>(group_[i])]) group_[i] = static_cast<std::int32_t>(rest);
  }
  double rest_weight = 0.0;
  for (std::size_t i = 0; i < n; ++i) rest_weight += group_[i] == static_cast<std::int32_t>(rest) ? weights_[i] : 0.0;
  counts[rest] =
      rest_weight > 0.0 ? static_cast<std::size_t>(std::lround(out.rest_share * static_cast<double>(budget))) : 0;
  // The challengers' pool: the places outside the heaviest hypotheses keep refining, however light.
  if (rest_weight > 0.0 && params_.challenger_candidates > 0 && ever_concentrated_) {
    counts[rest] = std::max(counts[rest], std::max<std::size_t>(1, params_.challenger_candidates / 200));
  }
  std::size_t& kept = out.kept;
  for (std::size_t c : counts) kept += c;
  if (kept > room) {  // floors of many hypotheses over the cap: everyone shrinks alike
    const double scale = static_cast<double>(room) / static_cast<double>(kept);
    kept = 0;
    for (std::size_t& c : counts) kept += (c = static_cast<std::size_t>(std::floor(static_cast<double>(c) * scale)));
  }
  if (kept == 0) {  // rounding left nothing: keep the dominant hypothesis
    counts[kept_group[0] ? 0 : rest] = std::max<std::size_t>(1, std::min(room, budget));
    kept = counts[kept_group[0] ? 0 : rest];
  }
  return out;
}

void ParticleFilter::resample(std::size_t n, std::size_t budget, const Injection& injection,
                              const std::vector<Eigen::Vector3f>& points, FilterStep& step) {
  const std::size_t injected = std::min(injection.count, params_.kld.max_particles);
  if (injection.candidates > injected) reserve_search(injection.candidates);  // before any view is taken
  const GroupCounts plan = count_groups(n, budget, params_.kld.max_particles - injected);
  const std::size_t kept = plan.kept;

  Rng rng(params_.seed, 0x2E5A3Bull, step_);
  group_resampler_.resample(params_.resample_method, weights_.data(), group_.data(), n, plan.counts, rng,
                            ancestors_.data());
  const ParticleArrays src = evaluator_.particles();
  const ParticleArrays dst = evaluator_.spare_particles();
  for (std::size_t j = 0; j < kept; ++j) {
    const std::uint32_t a = ancestors_[j];
    dst.x[j] = src.x[a];
    dst.y[j] = src.y[a];
    dst.z[j] = src.z[a];
    dst.qw[j] = src.qw[a];
    dst.qx[j] = src.qx[a];
    dst.qy[j] = src.qy[a];
    dst.qz[j] = src.qz[a];
  }
  if (injected > 0) inject(injection, injected, points, dst, kept);
  set_prior_weights(plan, injected, injection.share);
  evaluator_.swap_particles();
  injected_begin_ = kept;
  injected_end_ = kept + injected;
  count_ = kept + injected;
  updates_since_resample_ = 0;
  step.resampled = true;
}

void ParticleFilter::inject(const Injection& injection, std::size_t injected,
                            const std::vector<Eigen::Vector3f>& points, const ParticleArrays& dst, std::size_t offset) {
  if (injection.around) {
    const ParticleArrays at{dst.x + offset,  dst.y + offset,          dst.z + offset,
                            dst.qw + offset, dst.qx + offset,         dst.qy + offset,
                            dst.qz + offset, dst.log_weight + offset, dst.capacity - offset};
    LocalInitSpread tight;
    tight.sigma_xy = 0.1;
    tight.sigma_z = 0.05;
    tight.sigma_yaw = 0.05;
    tight.sigma_roll_pitch = 0.02;
    sample_local(at, injected, *injection.around, tight, params_.seed, step_);
  } else if (injection.candidates > injected)
    search(injection.candidates, injected, points, dst, offset);
  else
    proposal().sample(dst, offset, offset + injected, params_.seed, step_);
}

void ParticleFilter::set_prior_weights(const GroupCounts& plan, std::size_t injected, double injection_share) {
  // Each group's share is spread over its new particles. The injected particles carry the injection's share of
  // the belief, however many they are: many, to cover the map; a small share, while the evidence for a lost
  // track is weak (a correct track's fit dips now and then).
  const double injected_share = injected > 0 ? std::clamp(injection_share, 1e-9, 1.0 - 1e-6) : 0.0;
  const std::size_t groups = plan.counts.size();
  const std::size_t rest = groups - 1;
  std::size_t j = 0;
  for (std::size_t g = 0; g < groups; ++g) {
    const double share = g == rest ? plan.rest_share : group_share_[g];
    const double log_w =
        std::log(std::max(share, 1e-300) / static_cast<double>(std::max<std::size_t>(plan.counts[g], 1))) +
        std::log1p(-injected_share);
    for (std::size_t c = 0; c < plan.counts[g]; ++c) prior_log_weight_[j++] = log_w;
  }
  const double injected_log_w = injected > 0 ? std::log(injected_share / static_cast<double>(injected)) : 0.0;
  for (std::size_t i = plan.kept; i < plan.kept + injected; ++i) prior_log_weight_[i] = injected_log_w;
}

}  // namespace tsdf_mcl
