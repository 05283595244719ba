// ParticleFilter's resampling: when to resample, what joins the next generation (recovery, challengers, a place the
// ledger favours) and the generation drawn per place (filter_core.hpp).
#include <algorithm>
#include <cmath>

#include "filter_core.hpp"
#include "tsdf_mcl/core/random.hpp"

namespace tsdf_mcl {

void ParticleFilter::Core::resample_policy(double time, std::size_t n, const std::vector<Eigen::Vector3f>& points,
                                           const ScanExtras& extras, FilterStep& step) {
  ++updates_since_resample_;
  fresh_particles_weighed_ = false;
  bool resampled = false;
  if (updates_since_resample_ >= params_.resample_interval) {
    const Injection injection = plan_injection(time, step);
    const std::size_t injected = injection.count;
    const std::size_t max = params_.kld.max_particles;
    const std::size_t budget =
        std::min(kld_.required_count(evaluator_.particles(), weights_.data(), n), max - injected);
    step.kld_bins = kld_.occupied_bins();
    const bool depleted = step.ess < params_.resample_ess_ratio * static_cast<double>(n);
    const bool resize = budget + injected < n / 2 || budget + injected > n;
    // Injected hypotheses follow this scan's up direction and floor height, like a global search's. Challengers of a
    // converged track keep its up direction, as an IMU's gravity would: a sideways or upside-down look-alike has no
    // say then (a drone under the ceiling fits a flipped sensor above the floor); a wrong lock is left by the
    // implausible-fit search, which considers every direction again.
    std::optional<Eigen::Vector3f> up = extras.imu_up;
    if (!up && converged_once() && step.random_share == 0.0) {
      up = (estimate_.pose.linear().transpose().cast<float>() * proposal().map_up()).normalized();
    }
    if (injected > 0 && (extras.dense || up)) proposal().use_scan(extras.dense ? *extras.dense : points, up);
    if (depleted || resize || injected > 0) {
      resample(n, budget, injection, points, step);
      resampled = true;
      fresh_particles_weighed_ = injected > 0 && !injection.around;
      if (step.random_share > 0.0) {
        step.injected = injected;
      } else if (injection.around) {
        step.restored = injected;
      } else if (injected > 0) {
        last_challenge_time_ = time;
        step.challengers = injected;
      }
    }
  }
  if (!resampled) std::copy_n(post_log_weight_.begin(), n, prior_log_weight_.begin());
}

ParticleFilter::Core::Injection ParticleFilter::Core::plan_injection(double time, const FilterStep& step) const {
  Injection in;
  const std::size_t max = params_.kld.max_particles;
  // Particles put tightly around one place the ledger favours: as many as a kept place.
  const std::size_t around_count =
      std::min(max, std::max<std::size_t>(params_.places.min_particles, params_.kld.min_particles));
  if (step.random_share > 0.0) {
    // Recovery. After an implausible fit the track is wrong and the search starts over: screened on this scan
    // like a global search. After a dip of the relative fit (a correct track shows them now and then) drawn as
    // they come: only a lost track lets such guesses win.
    in.count = std::min(max, static_cast<std::size_t>(std::lround(step.random_share * static_cast<double>(max))));
    in.candidates =
        step.implausible ? std::max(in.count, std::min(10 * in.count, params_.global_search.candidates)) : in.count;
    in.share = step.random_share;
  } else if (restore_) {
    // A place the ledger favours of which the belief holds too little: as many particles as a kept place, with the
    // share the ledger gives it (filter_decision.cpp: plan_restore).
    in.count = around_count;
    in.candidates = in.count;
    in.share = restore_->share;
    in.around = restore_->place;
  } else if (params_.recovery.challenger_candidates > 0 &&
             (concentrated_once() || (local_start_ && step_ >= params_.states.min_updates)) &&
             time - last_challenge_time_ >= params_.recovery.challenger_interval) {
    // A local start's particles cover only the given pose's neighbourhood: one whose belief has not concentrated in
    // the updates a claim takes (a wrong pose that fits nowhere near) is questioned as a concentrated one is.
    in.candidates = params_.recovery.challenger_candidates;
    in.count = std::max<std::size_t>(1, in.candidates / 200);
    // A tenth of a credible share: one scan that a challenger explains clearly better makes it credible.
    in.share = params_.places.credible_weight / 10.0;
  }
  return in;
}

ParticleFilter::Core::GroupCounts ParticleFilter::Core::count_groups(std::size_t n, std::size_t budget,
                                                                     std::size_t room) {
  // Particle counts per group: each place heavy enough to keep at least PlaceOptions::min_particles, the rest of the
  // budget by share. Lighter places join the rest and take their chances.
  const std::size_t groups = group_share_.size();
  const std::size_t rest = groups - 1;
  GroupCounts out;
  std::vector<std::size_t>& counts = out.counts;
  counts.assign(groups, 0);
  std::vector<bool> kept_group(groups, false);
  out.rest_share = group_share_[rest];
  for (std::size_t g = 0; g < rest; ++g) {
    if (group_share_[g] >= params_.places.min_weight) {
      kept_group[g] = true;
      counts[g] = std::max(params_.places.min_particles,
                           static_cast<std::size_t>(std::lround(group_share_[g] * static_cast<double>(budget))));
    } else {
      out.rest_share += group_share_[g];
    }
  }
  // Every credible place (PlaceOptions::credible_weight) gets as many particles as the largest:
  // with fewer, its mean sits a little off, its fit at its refined pose comes out a little worse, and the
  // evidence drifts towards whichever look-alike happened to hold more particles.
  // (Only the kept ones: with min_weight above credible_weight a credible place may have joined
  // the rest, its group left without particles.)
  const auto credible = [&](std::size_t g) {
    return kept_group[g] && group_share_[g] >= params_.places.credible_weight;
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
  // The challengers' pool: the places outside the heaviest ones keep refining, however light.
  if (rest_weight > 0.0 && params_.recovery.challenger_candidates > 0 && concentrated_once()) {
    counts[rest] = std::max(counts[rest], std::max<std::size_t>(1, params_.recovery.challenger_candidates / 200));
  }
  std::size_t& kept = out.kept;
  for (std::size_t c : counts) kept += c;
  if (kept > room) {  // floors of many places over the cap: everyone shrinks alike
    const double scale = static_cast<double>(room) / static_cast<double>(kept);
    kept = 0;
    for (std::size_t& c : counts) kept += (c = static_cast<std::size_t>(std::floor(static_cast<double>(c) * scale)));
  }
  if (kept == 0) {  // rounding left nothing: keep the dominant place
    counts[kept_group[0] ? 0 : rest] = std::max<std::size_t>(1, std::min(room, budget));
    kept = counts[kept_group[0] ? 0 : rest];
  }
  return out;
}

void ParticleFilter::Core::resample(std::size_t n, std::size_t budget, const Injection& injection,
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

void ParticleFilter::Core::inject(const Injection& injection, std::size_t injected,
                                  const std::vector<Eigen::Vector3f>& points, const ParticleArrays& dst,
                                  std::size_t offset) {
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

void ParticleFilter::Core::set_prior_weights(const GroupCounts& plan, std::size_t injected, double injection_share) {
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
