#include "tsdf_mcl/particle_filter.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "cpu/weight_reduction.hpp"
#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// The constant-velocity model trusts the motion between two estimates only while both are this certain (m,
// standard deviation of the dominant mode): looser than `converged`, so that a track still settling after a
// local initialization already has a velocity, but far below the spread of a global belief.
constexpr double kVelocityMaxStd = 0.5;

// Tempered weights exp(prior + beta * l - max) into w; returns their effective sample size.
double tempered(const double* prior, const float* l, std::size_t n, double beta, double* w) {
  double max = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < n; ++i) max = std::max(max, prior[i] + beta * l[i]);
  for (std::size_t i = 0; i < n; ++i) w[i] = std::exp(prior[i] + beta * l[i] - max);
  return effective_sample_size(w, n);
}

}  // namespace

void FilterParameters::validate() const {
  if (initial_particles == 0) throw Error("--particles must be at least 1");
  kld.validate();
  if (resample_interval == 0) throw Error("resample_interval must be at least 1");
  if (!(resample_ess_ratio >= 0.0 && resample_ess_ratio <= 1.0)) throw Error("resample_ess_ratio must lie in [0, 1]");
  if (!(min_ess_ratio >= 0.0 && min_ess_ratio < 1.0)) throw Error("min_ess_ratio must lie in [0, 1)");
  RecoveryMonitor{recovery_alpha_slow, recovery_alpha_fast, recovery_margin};  // throws for bad alphas
  sensor.validate();
  motion.validate();
  if (!(update_min_d >= 0.0) || !std::isfinite(update_min_d)) throw Error("update_min_d must not be negative");
  if (!(update_min_a >= 0.0) || !std::isfinite(update_min_a)) throw Error("update_min_a must not be negative");
  if (!(roughening_xyz >= 0.0) || !std::isfinite(roughening_xyz)) throw Error("roughening_xyz must not be negative");
  if (!(roughening_angle >= 0.0) || !std::isfinite(roughening_angle)) throw Error("roughening_angle must not be negative");
  if (!(roughening_interval >= 0.0) || !std::isfinite(roughening_interval)) {
    throw Error("roughening_interval must not be negative");
  }
  global_init.validate();
  local_init.validate();
  estimate.validate();
}

ParticleFilter::ParticleFilter(const TsdfMap& map, SensorEvaluator& evaluator, const FilterParameters& params,
                               std::size_t points_hint)
    : map_(map),
      evaluator_(evaluator),
      params_(params),
      kld_(params.kld),
      estimator_(params.estimate),
      recovery_(params.recovery_alpha_slow, params.recovery_alpha_fast, params.recovery_margin) {
  params_.validate();
  if (map.empty()) throw Error("the map is empty");
  capacity_ = std::max(params_.initial_particles, params_.kld.max_particles);
  points_capacity_ = std::max<std::size_t>(points_hint, 1);
  evaluator_.reserve(capacity_, points_capacity_);
  prior_log_weight_.assign(capacity_, 0.0);
  weights_.assign(capacity_, 0.0);
  ancestors_.assign(capacity_, 0u);
}

const FreeSpaceSampler& ParticleFilter::sampler() {
  if (!sampler_) sampler_ = std::make_unique<FreeSpaceSampler>(map_, params_.global_init);
  return *sampler_;
}

std::size_t ParticleFilter::free_space_voxels() { return sampler().candidate_voxels(); }

std::vector<double> ParticleFilter::particle_weights() const {
  std::vector<double> w(prior_log_weight_.begin(), prior_log_weight_.begin() + static_cast<std::ptrdiff_t>(count_));
  if (w.empty()) return w;
  const double max = *std::max_element(w.begin(), w.end());
  double sum = 0.0;
  for (double& v : w) sum += (v = std::exp(v - max));
  for (double& v : w) v /= sum;
  return w;
}

void ParticleFilter::start(std::size_t count) {
  count_ = count;
  std::fill_n(prior_log_weight_.begin(), count_, 0.0);
  initialized_ = true;
  has_update_ = false;
  last_odometry_.reset();
  velocity_delta_.reset();
  updates_since_resample_ = 0;
  injected_begin_ = injected_end_ = 0;
  recovery_.reset();
  ever_converged_ = false;
  estimate_ = PoseEstimate{};
}

void ParticleFilter::initialize_global() {
  const FreeSpaceSampler& s = sampler();
  s.sample(evaluator_.particles(), 0, params_.initial_particles, params_.seed, step_);
  ++step_;
  start(params_.initial_particles);
}

void ParticleFilter::initialize_local(const Pose& pose) {
  sample_local(evaluator_.particles(), params_.initial_particles, pose, params_.local_init, params_.seed, step_);
  ++step_;
  start(params_.initial_particles);
  estimate_.pose = pose;
  last_estimate_pose_ = pose;
}

void ParticleFilter::prepare_weights(std::size_t n, FilterStep& step) {
  const ParticleArrays p = evaluator_.particles();
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(p.log_weight[i])) {
      throw Error("sensor update gave particle " + std::to_string(i) + " a non-finite weight");
    }
  }
  // Freshly injected random particles do not count: they are guesses, not belief, and a floor that grew with
  // them would hand their weight back to them whenever recovery floods a converged set.
  const std::size_t fresh = std::min(injected_end_, n) - std::min(injected_begin_, n);
  const double target = params_.min_ess_ratio * static_cast<double>(fresh < n ? n - fresh : n);
  double beta = 1.0;
  double ess = tempered(prior_log_weight_.data(), p.log_weight, n, 1.0, weights_.data());
  if (ess < target) {
    // ESS falls as beta grows (the weights sharpen): bisect for the largest beta that keeps the target, in
    // log(beta) because useful values span orders of magnitude (1e-4 for a global belief of 100k particles).
    double lo = std::log(1e-7);
    double hi = 0.0;
    for (int iteration = 0; iteration < 16; ++iteration) {
      const double mid = 0.5 * (lo + hi);
      if (tempered(prior_log_weight_.data(), p.log_weight, n, std::exp(mid), weights_.data()) >= target) {
        lo = mid;
      } else {
        hi = mid;
      }
    }
    beta = std::exp(lo);
    ess = tempered(prior_log_weight_.data(), p.log_weight, n, beta, weights_.data());
  }
  for (std::size_t i = 0; i < n; ++i) prior_log_weight_[i] += beta * p.log_weight[i];
  step.tempering = beta;
  step.ess = ess;
}

double ParticleFilter::belief_fit(std::size_t n, const WeightSummary& summary, std::size_t points) const {
  const std::size_t begin = std::min(injected_begin_, n);
  const std::size_t end = std::min(injected_end_, n);
  if (begin == end || end - begin == n) return summary.fit_sum / static_cast<double>(n);
  // The evaluator's definition of a particle's fit, over the particles outside [begin, end).
  const FitConstants f = fit_constants(params_.sensor, points);
  const ParticleArrays p = evaluator_.particles();
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (i >= begin && i < end) continue;
    sum += std::exp(static_cast<double>(p.log_weight[i]) * f.scale + f.offset);
  }
  return sum / static_cast<double>(n - (end - begin));
}

void ParticleFilter::resample(std::size_t n, std::size_t kept, std::size_t injected, FilterStep& step) {
  Rng rng(params_.seed, 0x2E5A3Bull, step_);
  const std::size_t target = kept + injected;
  tsdf_mcl::resample(params_.resample_method, weights_.data(), n, kept, rng, ancestors_.data());
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
  if (injected > 0) sampler().sample(dst, kept, target, params_.seed, step_);
  injected_begin_ = kept;
  injected_end_ = target;
  evaluator_.swap_particles();
  count_ = target;
  std::fill_n(prior_log_weight_.begin(), count_, 0.0);
  updates_since_resample_ = 0;
  step.resampled = true;
  step.injected = injected;
}

FilterStep ParticleFilter::update(double time, const std::vector<Eigen::Vector3f>& points,
                                  const std::optional<Pose>& odometry) {
  const auto t_start = Clock::now();
  if (!initialized_) throw Error("the particle filter is not initialized");
  if (points.empty()) throw Error("empty scan: no points left for the sensor update");
  const bool use_odometry = params_.motion.type == MotionModelType::kOdometry;
  if (use_odometry && !odometry) {
    throw Error("motion_model odometry needs an odometry pose for every scan (odom.txt)");
  }
  FilterStep step;
  step.points = points.size();
  step.particles = count_;

  Pose delta = Pose::Identity();
  bool moved = true;
  if (has_update_) {
    switch (params_.motion.type) {
      case MotionModelType::kOdometry:
        delta = orthonormalized(last_odometry_->inverse() * *odometry);
        break;
      case MotionModelType::kConstantVelocity:
        if (velocity_delta_ && velocity_dt_ > 0.0) delta = scale_motion(*velocity_delta_, (time - last_time_) / velocity_dt_);
        break;
      case MotionModelType::kDiffusion:
        break;
    }
    // The gate needs measured motion: with a predicted one it could hold a filter still forever. Before the
    // first convergence a standing robot still gets an update every roughening_interval (see roughening).
    if (use_odometry) {
      moved = delta.translation().norm() >= params_.update_min_d ||
              Eigen::AngleAxisd(delta.linear()).angle() >= params_.update_min_a ||
              (!ever_converged_ && time - last_time_ >= params_.roughening_interval);
    }
  }
  if (!moved) {
    estimate_.pose = last_estimate_pose_ * delta;
    step.estimate = estimate_;
    step.next_particles = count_;
    step.timings.total_ms = ms_since(t_start);
    return step;
  }
  step.updated = true;
  const std::size_t n = count_;

  auto t0 = Clock::now();
  if (has_update_) {
    MotionNoise noise = motion_noise(params_.motion, delta, time - last_time_);
    if (!ever_converged_) {
      const auto rt = static_cast<float>(params_.roughening_xyz);
      const auto ra = static_cast<float>(params_.roughening_angle);
      noise.sigma_along = std::hypot(noise.sigma_along, rt);
      noise.sigma_across = std::hypot(noise.sigma_across, rt);
      noise.sigma_vertical = std::hypot(noise.sigma_vertical, rt);
      noise.sigma_roll = std::hypot(noise.sigma_roll, ra);
      noise.sigma_pitch = std::hypot(noise.sigma_pitch, ra);
      noise.sigma_yaw = std::hypot(noise.sigma_yaw, ra);
    }
    apply_motion(evaluator_.particles(), n, delta, noise, params_.seed, step_);
  }
  step.timings.motion_ms = ms_since(t0);

  if (points.size() > points_capacity_) {
    points_capacity_ = points.size();
    evaluator_.reserve(capacity_, points_capacity_);
  }
  evaluator_.set_points(points);
  const Eigen::Quaternionf reference(Eigen::Quaterniond(last_estimate_pose_.linear()).cast<float>());
  const WeightSummary summary = evaluator_.evaluate(n, params_.sensor, reference);
  const UpdateTimings& et = evaluator_.last_timings();
  step.timings.upload_ms = et.upload_ms;
  step.timings.weight_ms = et.evaluate_ms;
  step.timings.weight_gpu_ms = et.weight_gpu_ms;
  step.timings.reduce_gpu_ms = et.reduce_gpu_ms;

  t0 = Clock::now();
  prepare_weights(n, step);
  const bool was_localized = estimate_.std_position <= kVelocityMaxStd;
  estimate_ = estimator_.estimate(evaluator_.particles(), weights_.data(), n);
  step.fit = belief_fit(n, summary, points.size());
  // The fit averages start at the first convergence: a belief spread over the map fits badly by nature, and
  // a long-term average that remembers that phase would set the bar too low to ever notice a wrong lock.
  ever_converged_ = ever_converged_ || estimate_.converged;
  if (ever_converged_) step.random_share = recovery_.update(step.fit);
  step.w_slow = recovery_.w_slow();
  step.w_fast = recovery_.w_fast();
  // A concentrated cloud whose fit has collapsed is concentrated in the wrong place.
  if (step.random_share > 0.0) estimate_.converged = false;
  step.estimate = estimate_;
  step.timings.reduce_ms = ms_since(t0);

  if (params_.motion.type == MotionModelType::kConstantVelocity) {
    // Only a localized track has a velocity; the jumps of a spread belief's estimate are not motion.
    const bool localized = estimate_.std_position <= kVelocityMaxStd;
    if (has_update_ && was_localized && localized && time > last_time_) {
      velocity_delta_ = last_estimate_pose_.inverse() * estimate_.pose;
      velocity_dt_ = time - last_time_;
    } else {
      velocity_delta_.reset();
    }
  }

  t0 = Clock::now();
  ++updates_since_resample_;
  if (updates_since_resample_ >= params_.resample_interval) {
    const std::size_t max = params_.kld.max_particles;
    const auto injected = std::min(max, static_cast<std::size_t>(std::lround(step.random_share * static_cast<double>(max))));
    const std::size_t kept = std::min(kld_.required_count(evaluator_.particles(), weights_.data(), n), max - injected);
    step.kld_bins = kld_.occupied_bins();
    const bool depleted = step.ess < params_.resample_ess_ratio * static_cast<double>(n);
    const bool resize = kept + injected < n / 2 || kept + injected > n;
    if (depleted || resize || injected > 0) resample(n, kept, injected, step);
  }
  step.timings.resample_ms = ms_since(t0);
  step.next_particles = count_;

  has_update_ = true;
  last_time_ = time;
  if (odometry) last_odometry_ = *odometry;
  last_estimate_pose_ = estimate_.pose;
  ++step_;
  step.timings.total_ms = ms_since(t_start);
  return step;
}

}  // namespace tsdf_mcl
