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
#include "tsdf_mcl/filter/scan_gravity.hpp"

namespace tsdf_mcl {
namespace {

// The constant-velocity model trusts the motion between two estimates only while both are this certain (m,
// standard deviation of the dominant mode): looser than `converged`, so that a track still settling after a
// local initialization already has a velocity, but far below the spread of a global belief.
constexpr double kVelocityMaxStd = 0.5;

}  // namespace

void GlobalSearchOptions::validate() const {
  if (screen_points == 0) throw Error("init_screen_points must be at least 1");
  if (!(screen_sigma > 0.0f) || !std::isfinite(screen_sigma)) throw Error("init_screen_sigma must be positive");
  proposal.validate();
}

void FilterParameters::validate() const {
  if (initial_particles == 0) throw Error("--particles must be at least 1");
  kld.validate();
  if (resample_interval == 0) throw Error("resample_interval must be at least 1");
  if (!(resample_ess_ratio >= 0.0 && resample_ess_ratio <= 1.0)) throw Error("resample_ess_ratio must lie in [0, 1]");
  if (!(min_ess_ratio >= 0.0 && min_ess_ratio < 1.0)) throw Error("min_ess_ratio must lie in [0, 1)");
  subset_first.validate();
  RecoveryMonitor{recovery_alpha_slow, recovery_alpha_fast, recovery_margin};  // throws for bad alphas
  sensor.validate();
  motion.validate();
  if (!(update_min_d >= 0.0) || !std::isfinite(update_min_d)) throw Error("update_min_d must not be negative");
  if (!(update_min_a >= 0.0) || !std::isfinite(update_min_a)) throw Error("update_min_a must not be negative");
  if (!(roughening_xyz >= 0.0) || !std::isfinite(roughening_xyz)) throw Error("roughening_xyz must not be negative");
  if (!(roughening_angle >= 0.0) || !std::isfinite(roughening_angle))
    throw Error("roughening_angle must not be negative");
  if (!(roughening_interval >= 0.0) || !std::isfinite(roughening_interval)) {
    throw Error("roughening_interval must not be negative");
  }
  if (!(hypothesis_evidence_points >= 0.0) || !std::isfinite(hypothesis_evidence_points)) {
    throw Error("hypothesis_evidence_points must not be negative");
  }
  if (!(decisive_inlier_gap >= 0.0 && decisive_inlier_gap <= 1.0))
    throw Error("decisive_inlier_gap must lie in [0, 1]");
  if (!(estimate_switch_ratio >= 1.0) || !std::isfinite(estimate_switch_ratio))
    throw Error("estimate_switch_ratio must be at least 1");
  if (!(hypothesis_min_weight > 0.0 && hypothesis_min_weight <= 1.0))
    throw Error("hypothesis_min_weight must lie in (0, 1]");
  if (!(inlier_distance > 0.0f) || !std::isfinite(inlier_distance)) throw Error("inlier_distance must be positive");
  if (!(wall_tilt_information >= 0.0) || !std::isfinite(wall_tilt_information))
    throw Error("wall_tilt_information must not be negative");
  if (!(see_through_weight >= 0.0) || !std::isfinite(see_through_weight))
    throw Error("see_through_weight must not be negative");
  if (!(recovery_min_inliers >= 0.0 && recovery_min_inliers <= 1.0))
    throw Error("recovery_min_inliers must lie in [0, 1]");
  if (!(challenger_interval >= 0.0) || !std::isfinite(challenger_interval))
    throw Error("challenger_interval must not be negative");
  convergence.validate();
  track.validate();
  look_alikes.validate();
  if (!(ambiguous_weight >= 0.0 && ambiguous_weight <= 1.0)) throw Error("ambiguous_weight must lie in [0, 1]");
  global_init.validate();
  global_search.validate();
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
      recovery_(params.recovery_alpha_slow, params.recovery_alpha_fast, params.recovery_margin),
      convergence_(params.convergence),
      keeper_(params.track),
      look_alikes_(
          map, params.look_alikes,
          [this](const Pose& a, const Pose& b, const std::vector<Eigen::Vector3f>& points) {
            return judge_places(a, b, points);
          },
          params.convergence.max_jump_m, params.convergence.max_jump_rad),
      subset_first_(params.subset_first),
      motion_(params.motion.type) {
  params_.validate();
  if (map.empty()) throw Error("the map is empty");
  if (params_.unknown_as_free) params_.sensor.unknown_distance = map.truncation();
  // A global search needs more room in the evaluator (its scratch space) only while it runs: see
  // reserve_search(); the host arrays follow the particle set, which never exceeds this.
  capacity_ = std::max(params_.initial_particles, params_.kld.max_particles);
  points_capacity_ = std::max<std::size_t>(points_hint, 1);
  evaluator_.reserve(capacity_, points_capacity_);
  prior_log_weight_.assign(capacity_, 0.0);
  post_log_weight_.assign(capacity_, 0.0);
  weights_.assign(capacity_, 0.0);
  group_.assign(capacity_, 0);
  ancestors_.assign(capacity_, 0u);
}

GlobalProposal& ParticleFilter::proposal() {
  if (!proposal_)
    proposal_ = std::make_unique<GlobalProposal>(map_, params_.global_init, params_.global_search.proposal);
  return *proposal_;
}

WallTilt ParticleFilter::walls_at(const Pose& pose) {
  if (!(params_.wall_tilt_information > 0.0)) return WallTilt{};  // without building the proposal for map_up
  return select_walls(scan_normals_, pose, proposal().map_up().cast<double>(),
                      wall_information(params_.wall_tilt_information, scan_points_));
}

std::size_t ParticleFilter::free_space_voxels() { return proposal().free_space().candidate_voxels(); }

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
  motion_.reset();
  updates_since_resample_ = 0;
  injected_begin_ = injected_end_ = 0;
  recovery_.reset();
  convergence_.reset();
  keeper_.reset();
  look_alikes_.reset();
  restore_pending_ = false;
  look_alike_to_restore_.reset();
  trusted_ = false;
  ever_converged_ = false;
  ever_concentrated_ = false;
  places_named_ = false;
  decisive_before_.clear();
  local_start_ = false;
  dominant_concentrated_ = false;
  covered_streak_ = 0;
  mapped_track_ = false;
  implausible_streak_ = 0;
  last_challenge_time_ = -1e300;
  challengers_weighed_ = false;
  estimate_ = PoseEstimate{};
  estimate_placed_ = false;
  state_ = TrackState::kSearching;
}

void ParticleFilter::initialize_local(const Pose& pose) { initialize_local(pose, params_.local_init); }

void ParticleFilter::initialize_local(const Pose& pose, const LocalInitSpread& spread) {
  spread.validate();
  sample_local(evaluator_.particles(), params_.initial_particles, pose, spread, params_.seed, step_);
  ++step_;
  start(params_.initial_particles);
  local_start_ = true;
  estimate_.pose = pose;
  last_estimate_pose_ = pose;
  estimate_placed_ = true;
}

bool ParticleFilter::calls_for_update(const Pose& delta, double time) {
  bool moved = true;
  // The gate needs measured motion: with a predicted one it could hold a filter still forever. Before the first
  // convergence a standing robot still gets an update every roughening_interval (see roughening).
  if (motion_.has_update() && params_.motion.type == MotionModelType::kOdometry) {
    moved = delta.translation().norm() >= params_.update_min_d ||
            Eigen::AngleAxisd(delta.linear()).angle() >= params_.update_min_a ||
            (!ever_converged_ && motion_.elapsed(time) >= params_.roughening_interval);
  }
  moved = moved || force_update_;
  force_update_ = false;
  return moved;
}

void ParticleFilter::predict(std::size_t n, const Pose& delta, double dt) {
  if (!motion_.has_update()) return;
  MotionNoise noise = motion_noise(params_.motion, delta, dt);
  // Roughening serves a sparse belief; once its dominant hypothesis holds the belief, concentrated, the motion noise
  // keeps that cloud alive, and a random walk of roughening_xyz per update lets a likelihood that favours one side
  // (a drone whose map lacks the band above the mapping robot's view: every particle below fits it better) carry
  // the cloud off, 0.85 m down over 3 s in the symmetric building, before the filter first converges.
  if (!ever_converged_ && !dominant_concentrated_) {
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

WeightSummary ParticleFilter::weigh_scan(std::size_t n, const std::vector<Eigen::Vector3f>& points, FilterStep& step) {
  if (points.size() > points_capacity_) {
    points_capacity_ = points.size();
    evaluator_.reserve(capacity_, points_capacity_);
  }
  const Eigen::Quaternionf reference(Eigen::Quaterniond(last_estimate_pose_.linear()).cast<float>());
  UpdateTimings et;
  // A global search until the belief first concentrates (not after a local start): subset first's middle pass.
  const bool global_search = !local_start_ && !ever_concentrated_;
  const WeightSummary summary =
      subset_first_.weigh(evaluator_, n, points, params_.sensor, reference, &et, global_search);
  step.timings.upload_ms = et.upload_ms;
  step.timings.weight_ms = et.evaluate_ms;
  step.timings.weight_gpu_ms = et.weight_gpu_ms;
  step.timings.reduce_gpu_ms = et.reduce_gpu_ms;
  return summary;
}

double ParticleFilter::weigh_evidence(std::size_t n, const std::vector<Eigen::Vector3f>& points,
                                      const WeightSummary& summary, FilterStep& step) {
  Stopwatch t0;
  prepare_weights(n, step);
  step.timings.tempering_ms = t0.ms();
  t0 = Stopwatch();
  weigh_hypotheses(n, points, step);
  step.timings.hypotheses_ms = t0.ms();
  step.fit = belief_fit(n, summary, points.size());
  // Recovery follows the dominant hypothesis's inlier ratio: it falls when the track is lost and hardly moves
  // on a correct one (the likelihood-based fit dips by a third whenever the cloud spreads in a turn). The
  // averages start at the first convergence: a belief spread over the map fits badly by nature, and a long-term
  // average that remembers that phase would set the bar too low to ever notice a lost track.
  // Where the map covers too little of the scan at a trusted track the fit says nothing: the averages wait.
  if (ever_converged_ && (!trusted_track() || map_judges_track())) step.random_share = recovery_.update(judged_ratio());
  step.w_slow = recovery_.w_slow();
  step.w_fast = recovery_.w_fast();
  const double implausible_share = judge_fit(step);
  step.random_share = std::max(step.random_share, implausible_share);
  return implausible_share;
}

void ParticleFilter::decide(const Pose& delta, double dt, const std::vector<Eigen::Vector3f>& points,
                            double implausible_share, FilterStep& step) {
  challengers_weighed_ = challengers_weighed_ || last_challenge_time_ > -1e300;
  keep_track(delta, dt, points, step);
  remember_look_alikes(delta, points, step);
  // Recovery moving more of the belief elsewhere than converged_weight allows outside the dominant mode: lost.
  estimate_.converged = convergence_.update(
      estimate_, step.concentrated && !step.holding, delta, step.random_share > 1.0 - params_.estimate.converged_weight,
      challengers_weighed_ || params_.challenger_candidates == 0, !step.look_alikes.empty());
  step.challenged = convergence_.challenged(estimate_) || !step.look_alikes.empty();
  // Trust is earned where the map covers the scan (converged at converged_min_coverage) and lost only where it
  // covers most of it: in a room the mapping run never entered the particles spread and `converged` lapses, which
  // on a scan at the edge of the coverage threshold must not turn the track into an off-map belief.
  if (estimate_.converged && !(estimate_.coverage < params_.convergence.min_coverage)) trusted_ = true;
  // Nor is it lost while the dominant hypothesis still continues the kept track: a faint challenger alone (a
  // look-alike's share of a few thousandths as the robot nears a skipped room) lapses `converged`, not the track.
  if (!estimate_.converged && map_judges_track() && !track_followed_) trusted_ = false;
  if (!keeper_.active() && estimate_.converged) {
    keeper_.start(estimate_.pose);
    track_covariance_ = estimate_.covariance;
  }
  ever_converged_ = ever_converged_ || estimate_.converged;
  if (implausible_share > 0.0) {
    // A wrong lock: search again as after a global initialization (roughening, averages forgotten).
    keeper_.reset();
    look_alikes_.reset();
    look_alike_to_restore_.reset();
    ever_converged_ = false;
    local_start_ = false;
    recovery_.reset();
    convergence_.restart_after_wrong_lock();
    challengers_weighed_ = false;
    last_challenge_time_ = -1e300;
    covered_streak_ = 0;
    mapped_track_ = false;
  }
  step.state = state_ = classify(step);
  step.estimate = estimate_;
}

void ParticleFilter::resample_policy(double time, std::size_t n, const std::vector<Eigen::Vector3f>& points,
                                     const ScanExtras& extras, FilterStep& step) {
  ++updates_since_resample_;
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
    // Injected hypotheses follow this scan's up direction and floor height, like a global search's. Challengers
    // of a converged track keep its up direction, as an IMU's gravity would: the sensor's tilt changes between
    // scans only as the odometry says, and the track knows it to a fraction of a degree. A sideways or
    // upside-down look-alike has no say then (a drone under the ceiling fits a flipped sensor above the
    // floor); a wrong lock is left by the implausible-fit search, which considers every direction again.
    std::optional<Eigen::Vector3f> up = extras.imu_up;
    if (!up && ever_converged_ && step.random_share == 0.0) {
      up = (estimate_.pose.linear().transpose().cast<float>() * proposal().map_up()).normalized();
    }
    if (injected > 0 && (extras.dense || up)) proposal().use_scan(extras.dense ? *extras.dense : points, up);
    if (depleted || resize || injected > 0) {
      resample(n, budget, injection, points, step);
      resampled = true;
      if (step.random_share > 0.0) {
        step.injected = injected;
      } else if (injection.look_alike) {
        step.look_alike_restored = injected;
        look_alike_to_restore_.reset();
      } else if (injection.around) {
        step.restored = injected;
        restore_pending_ = false;
      } else if (injected > 0) {
        last_challenge_time_ = time;
        step.challengers = injected;
      }
    }
  }
  if (!resampled) std::copy_n(post_log_weight_.begin(), n, prior_log_weight_.begin());
}

FilterStep ParticleFilter::update(double time, const std::vector<Eigen::Vector3f>& points,
                                  const std::optional<Pose>& odometry, const ScanExtras& extras) {
  const Stopwatch t_start;
  if (!initialized_) throw Error("the particle filter is not initialized");
  if (points.empty()) throw Error("empty scan: no points left for the sensor update");
  if (params_.motion.type == MotionModelType::kOdometry && !odometry) {
    throw Error("motion_model odometry needs an odometry pose for every scan (odom.txt)");
  }
  FilterStep step;
  step.points = points.size();
  step.particles = count_;
  step.next_particles = count_;
  const std::size_t n = count_;

  // Motion gate: a robot that has not moved keeps its belief, the estimate carried along by the motion.
  const Pose delta = motion_.delta(time, odometry);
  if (!calls_for_update(delta, time)) {
    estimate_.pose = last_estimate_pose_ * delta;
    step.estimate = estimate_;
    step.state = state_;
    step.timings.total_ms = t_start.ms();
    return step;
  }
  step.updated = true;
  track_prediction_ = keeper_.active() ? std::optional<Pose>(keeper_.predict(delta)) : std::nullopt;
  estimate_prediction_ = estimate_placed_ ? std::optional<Pose>(last_estimate_pose_ * delta) : std::nullopt;
  update_delta_ = delta;
  Stopwatch t0;
  predict(n, delta, motion_.elapsed(time));
  step.timings.motion_ms = t0.ms();
  const WeightSummary summary = weigh_scan(n, points, step);
  t0 = Stopwatch();
  scan_normals_.clear();
  scan_points_ = points.size();
  if (params_.wall_tilt_information > 0.0) scan_normals_ = planar_normals(extras.dense ? *extras.dense : points);
  step.timings.walls_ms = t0.ms();
  weigh_track_on_evidence(n, points, delta, step);

  t0 = Stopwatch();
  const bool was_localized = estimate_.std_position <= kVelocityMaxStd;
  const double implausible_share = weigh_evidence(n, points, summary, step);
  decide(delta, motion_.elapsed(time), points, implausible_share, step);
  step.timings.reduce_ms = t0.ms();
  // Only a localized track has a velocity; the jumps of a spread belief's estimate are not motion.
  motion_.observe_estimate(time, last_estimate_pose_, estimate_.pose,
                           was_localized && estimate_.std_position <= kVelocityMaxStd);

  t0 = Stopwatch();
  resample_policy(time, n, points, extras, step);
  step.timings.resample_ms = t0.ms();
  step.next_particles = count_;

  motion_.finish_update(time, odometry);
  last_estimate_pose_ = estimate_.pose;
  estimate_placed_ = true;
  ++step_;
  step.timings.total_ms = t_start.ms();
  return step;
}

}  // namespace tsdf_mcl
