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
namespace {

// The constant-velocity model trusts the motion between two estimates only while both are this certain (m,
// standard deviation of the dominant mode): looser than `converged`, so that a track still settling after a
// local initialization already has a velocity, but far below the spread of a global belief.
constexpr double kVelocityMaxStd = 0.5;

// Tempered weights exp(prior + beta * l - max) into w; returns their effective sample size.
// The max and the exps in parallel (the tempering's bisection calls this 18 times an update: 7 ms for 100k
// particles on one core); the sums sequential, so the result does not depend on the thread count.
double tempered(const double* prior, const float* l, std::size_t n, double beta, double* w) {
  const auto count = static_cast<std::ptrdiff_t>(n);
  double max = -std::numeric_limits<double>::infinity();
#pragma omp parallel for schedule(static) reduction(max : max) if (n >= kParallelParticles)
  for (std::ptrdiff_t i = 0; i < count; ++i) max = std::max(max, prior[i] + beta * l[i]);
#pragma omp parallel for schedule(static) if (n >= kParallelParticles)
  for (std::ptrdiff_t i = 0; i < count; ++i) w[i] = std::exp(prior[i] + beta * l[i] - max);
  return effective_sample_size(w, n);
}

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
  if (!(hypothesis_min_weight > 0.0 && hypothesis_min_weight <= 1.0))
    throw Error("hypothesis_min_weight must lie in (0, 1]");
  if (!(inlier_distance > 0.0f) || !std::isfinite(inlier_distance)) throw Error("inlier_distance must be positive");
  if (!(recovery_min_inliers >= 0.0 && recovery_min_inliers <= 1.0))
    throw Error("recovery_min_inliers must lie in [0, 1]");
  if (!(challenger_interval >= 0.0) || !std::isfinite(challenger_interval))
    throw Error("challenger_interval must not be negative");
  convergence.validate();
  track.validate();
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
  restore_pending_ = false;
  trusted_ = false;
  ever_converged_ = false;
  ever_concentrated_ = false;
  implausible_streak_ = 0;
  last_challenge_time_ = -1e300;
  challengers_weighed_ = false;
  estimate_ = PoseEstimate{};
  state_ = TrackState::kSearching;
}

void ParticleFilter::initialize_global() {
  GlobalProposal& g = proposal();
  g.use_uniform();
  g.sample(evaluator_.particles(), 0, params_.initial_particles, params_.seed, step_);
  ++step_;
  start(params_.initial_particles);
}

void ParticleFilter::initialize_global(const std::vector<Eigen::Vector3f>& points, const ScanExtras& extras) {
  if (points.empty()) throw Error("global initialization: the scan has no points");
  GlobalProposal& g = proposal();
  if (extras.dense || extras.imu_up)
    g.use_scan(extras.dense ? *extras.dense : points, extras.imu_up);
  else
    g.use_uniform();
  const std::size_t n = params_.initial_particles;
  if (params_.global_search.candidates > n) {
    reserve_search(params_.global_search.candidates);
    search(params_.global_search.candidates, n, points, evaluator_.spare_particles(), 0);
    evaluator_.swap_particles();
    climb(n, points);
  } else {
    g.sample(evaluator_.particles(), 0, n, params_.seed, step_);
  }
  ++step_;
  start(n);
}

namespace {

// The points a block of hypotheses is scored on, spread over the scan. For a gravity candidate, the rays
// within 20° of its horizon: they hit walls and furniture, which tell positions and headings apart, while
// floor and ceiling points fit any place at the right height (an OS0's +-45° beams are half floor and
// ceiling, and scored on them a million hypotheses ranked the right place with the wrong ones).
std::vector<Eigen::Vector3f> screening_points(const std::vector<Eigen::Vector3f>& points, const GravityCandidate* c,
                                              std::size_t count) {
  std::vector<Eigen::Vector3f> eligible;
  if (c) {
    const float horizon = std::sin(0.35f);
    for (const Eigen::Vector3f& p : points) {
      if (std::abs(p.dot(c->up)) <= horizon * p.norm()) eligible.push_back(p);
    }
  }
  const std::vector<Eigen::Vector3f>& from = eligible.size() >= count / 2 ? eligible : points;
  // The preprocessed points are in space-filling-curve order: every k-th one is spread over the scan.
  std::vector<Eigen::Vector3f> subset;
  const std::size_t every = std::max<std::size_t>(1, from.size() / count);
  for (std::size_t i = 0; i < from.size() && subset.size() < count; i += every) subset.push_back(from[i]);
  return subset;
}

}  // namespace

void ParticleFilter::climb(std::size_t n, const std::vector<Eigen::Vector3f>& points) {
  const GlobalSearchOptions& o = params_.global_search;
  if (o.climb_rounds == 0) return;
  constexpr std::size_t kTries = 3;  // jittered copies per particle and round
  if ((kTries + 1) * n > capacity_) {
    capacity_ = (kTries + 1) * n;
    evaluator_.reserve(capacity_, points_capacity_);
  }
  EndpointModel wide = params_.sensor;
  wide.sigma_hit = std::max(wide.sigma_hit, o.screen_sigma);
  wide.weight_exponent = 1.0f;
  wide.unknown_distance = map_.truncation();  // a smooth basin (EndpointModel::unknown_distance)
  std::vector<Eigen::Vector3f> subset;
  const std::size_t every = std::max<std::size_t>(1, points.size() / (2 * o.screen_points));
  for (std::size_t i = 0; i < points.size() && subset.size() < 2 * o.screen_points; i += every)
    subset.push_back(points[i]);
  if (subset.size() > points_capacity_) {
    points_capacity_ = subset.size();
    evaluator_.reserve(capacity_, points_capacity_);
  }
  evaluator_.set_points(subset);
  for (std::size_t round = 0; round < o.climb_rounds; ++round) {
    // Smaller steps each round: from about the screening's resolution down.
    const double scale = 1.0 / static_cast<double>(round + 1);
    const auto step_xyz = static_cast<float>(0.1 * scale);
    const auto step_angle = static_cast<float>(0.03 * scale);
    const ParticleArrays p = evaluator_.particles();
#pragma omp parallel for schedule(static) if (n >= kParallelParticles)
    for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(n); ++k) {
      const auto i = static_cast<std::size_t>(k);
      Rng rng(params_.seed, 0xC11B0ull + round, step_, i);
      for (std::size_t t = 0; t < kTries; ++t) {
        const Eigen::Vector3f dp(step_xyz * static_cast<float>(rng.normal()),
                                 step_xyz * static_cast<float>(rng.normal()),
                                 step_xyz * static_cast<float>(rng.normal()));
        const Eigen::Vector3f dr(step_angle * static_cast<float>(rng.normal()),
                                 step_angle * static_cast<float>(rng.normal()),
                                 step_angle * static_cast<float>(rng.normal()));
        p.set(n + kTries * i + t, p.position(i) + dp, (p.rotation(i) * quaternion_exp(dr)).normalized());
      }
    }
    evaluator_.evaluate((kTries + 1) * n, wide, Eigen::Quaternionf::Identity());
    // Each hypothesis moves to its best variant: a climb per hypothesis, no competition between them, so a
    // look-alike the screening found keeps its place beside the right one.
    const ParticleArrays dst = evaluator_.spare_particles();
    for (std::size_t i = 0; i < n; ++i) {
      std::size_t best = i;
      for (std::size_t t = 0; t < kTries; ++t) {
        const std::size_t c = n + kTries * i + t;
        if (p.log_weight[c] > p.log_weight[best]) best = c;
      }
      dst.set(i, p.position(best), p.rotation(best));
    }
    evaluator_.swap_particles();
  }
}

void ParticleFilter::reserve_search(std::size_t candidates) {
  const GlobalProposal& g = proposal();
  std::size_t largest = 0;
  for (std::size_t b = 0; b < g.blocks(); ++b) {
    largest =
        std::max(largest, static_cast<std::size_t>(std::lround(g.block_share(b) * static_cast<double>(candidates))));
  }
  if (largest > capacity_) {
    capacity_ = largest;
    evaluator_.reserve(capacity_, points_capacity_);
  }
}

void ParticleFilter::search(std::size_t candidates, std::size_t keep, const std::vector<Eigen::Vector3f>& points,
                            const ParticleArrays& dst, std::size_t offset) {
  const GlobalSearchOptions& o = params_.global_search;
  const GlobalProposal& g = proposal();
  // The kept hypotheses are shared between the blocks by their mixture weights (largest remainders).
  const std::size_t blocks = g.blocks();
  std::vector<std::size_t> keep_of(blocks, 0);
  std::vector<std::pair<double, std::size_t>> remainder;
  std::size_t assigned = 0;
  for (std::size_t b = 0; b < blocks; ++b) {
    const double exact = g.block_share(b) * static_cast<double>(keep);
    keep_of[b] = static_cast<std::size_t>(std::floor(exact));
    assigned += keep_of[b];
    remainder.emplace_back(exact - std::floor(exact), b);
  }
  std::sort(remainder.begin(), remainder.end(), [](const auto& a, const auto& b) {
    return a.first > b.first || (a.first == b.first && a.second < b.second);
  });
  for (std::size_t r = 0; assigned < keep; ++r, ++assigned) ++keep_of[remainder[r % blocks].second];

  EndpointModel wide = params_.sensor;
  wide.sigma_hit = std::max(wide.sigma_hit, o.screen_sigma);
  wide.weight_exponent = 1.0f;
  wide.unknown_distance = map_.truncation();  // a smooth basin (EndpointModel::unknown_distance)
  const ParticleArrays scratch = evaluator_.particles();
  std::vector<std::uint32_t> order;
  std::size_t written = 0;
  for (std::size_t b = 0; b < blocks; ++b) {
    if (keep_of[b] == 0) continue;
    const std::size_t m =
        std::clamp(static_cast<std::size_t>(std::lround(g.block_share(b) * static_cast<double>(candidates))),
                   keep_of[b], capacity_);
    g.sample_block(b, scratch, 0, m, params_.seed, step_);
    const std::vector<Eigen::Vector3f> subset = screening_points(points, g.block_candidate(b), o.screen_points);
    if (subset.size() > points_capacity_) {
      points_capacity_ = subset.size();
      evaluator_.reserve(capacity_, points_capacity_);
    }
    evaluator_.set_points(subset);
    evaluator_.evaluate(m, wide, Eigen::Quaternionf::Identity());
    order.resize(m);
    for (std::size_t i = 0; i < m; ++i) order[i] = static_cast<std::uint32_t>(i);
    const std::size_t k = keep_of[b];
    std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k - 1), order.end(),
                     [&](std::uint32_t a, std::uint32_t c) {
                       return scratch.log_weight[a] > scratch.log_weight[c] ||
                              (scratch.log_weight[a] == scratch.log_weight[c] && a < c);
                     });
    std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(k));
    for (std::size_t j = 0; j < k; ++j)
      dst.set(offset + written + j, scratch.position(order[j]), scratch.rotation(order[j]));
    written += k;
  }
}

void ParticleFilter::initialize_local(const Pose& pose) { initialize_local(pose, params_.local_init); }

void ParticleFilter::initialize_local(const Pose& pose, const LocalInitSpread& spread) {
  spread.validate();
  sample_local(evaluator_.particles(), params_.initial_particles, pose, spread, params_.seed, step_);
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
  for (std::size_t i = 0; i < n; ++i) post_log_weight_[i] = prior_log_weight_[i] + beta * p.log_weight[i];
  step.tempering = beta;
  step.ess = ess;
}

void ParticleFilter::weigh_hypotheses(std::size_t n, const std::vector<Eigen::Vector3f>& points, FilterStep& step) {
  estimate_ = estimator_.estimate(evaluator_.particles(), weights_.data(), n);
  std::vector<Hypothesis>& h = estimate_.hypotheses;
  const auto k = static_cast<std::int32_t>(h.size());
  for (std::size_t i = 0; i < n; ++i) {
    const std::int32_t g = estimator_.hypothesis_of(i);
    group_[i] = g >= 0 ? g : k;
  }
  // Each hypothesis's evidence: the mean log-likelihood per point at its mean pose refined onto the map (the
  // place's fit, not its particles' alignment); the refined pose is the hypothesis's estimate. The rest
  // (lighter modes, challengers, stray particles) have no one pose: theirs is their marginal likelihood per
  // point. A scan counts as hypothesis_evidence_points independent points, or as few as the tempering lets the
  // particles count it while that is fewer (a spread, global belief: no early verdict between its modes).
  EndpointModel plain = params_.sensor;
  plain.weight_exponent = 1.0f;
  const auto count = static_cast<double>(points.size());
  std::vector<double> evidence(h.size() + 1, 0.0);
  std::vector<Pose> refined(h.size());
  std::vector<std::vector<double>> point_log(h.size());
  std::vector<std::vector<std::uint8_t>> observed(h.size());
  std::vector<RayFit> fits(h.size());
  std::size_t reference = 0;  // the best-fitting hypothesis
  std::vector<double> totals(h.size(), 0.0);
  // Each hypothesis's heaviest particle: a second start for the refinement. A mode's mean sits off its place
  // while the mode is spread (a robot turning on the spot spreads its yaw), and a few Gauss-Newton steps from
  // there may not reach the place; judged at such a pose, the right room loses to its look-alike in one scan.
  std::vector<std::size_t> heaviest(h.size(), n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto g = static_cast<std::size_t>(group_[i]);
    if (g < h.size() && (heaviest[g] == n || weights_[i] > weights_[heaviest[g]])) heaviest[g] = i;
  }
  const ParticleArrays particles = evaluator_.particles();
  // The hypotheses' refinements are independent (the map is read-only): one per thread.
#pragma omp parallel for schedule(dynamic)
  for (std::ptrdiff_t rr = 0; rr < static_cast<std::ptrdiff_t>(h.size()); ++rr) {
    const auto r = static_cast<std::size_t>(rr);
    std::vector<double> candidate_log;
    totals[r] = -std::numeric_limits<double>::infinity();
    std::vector<Pose> starts{h[r].pose};
    if (heaviest[r] < n) {
      Pose best = Pose::Identity();
      best.linear() = particles.rotation(heaviest[r]).cast<double>().normalized().toRotationMatrix();
      best.translation() = particles.position(heaviest[r]).cast<double>();
      starts.push_back(best);
    }
    for (const Pose& start : starts) {
      const Pose candidate = refine_pose(map_, start, points);
      const Eigen::Quaternionf q(Eigen::Quaterniond(candidate.linear()).cast<float>());
      point_log_likelihoods(map_, plain, candidate.translation().cast<float>(), q, points, candidate_log);
      double total = 0.0;
      for (double l : candidate_log) total += l;
      if (total > totals[r]) {
        totals[r] = total;
        refined[r] = candidate;
        point_log[r].swap(candidate_log);
      }
    }
    fits[r] = ray_fit(map_, refined[r], points, params_.inlier_distance, 0.4f, &observed[r]);
  }
  for (std::size_t r = 0; r < h.size(); ++r) {
    if (totals[r] > totals[reference]) reference = r;
  }
  // Between places, only the points that one place explains and the other does not are evidence: each point's
  // log-likelihood difference to the best-fitting hypothesis counts beyond a dead band of what a point
  // inlier_distance off a surface loses. Two look-alike rooms differ in every point by the few millimetres
  // and tenths of a degree by which their refined poses happen to differ; summed over hundreds of points and
  // scans, those differences were a random walk that decided between identical places (within a few hundred
  // scans in the symmetric test building). A feature only one of them has (a cabinet) still moves its points by
  // the whole hit-versus-miss ratio of the model.
  const double dead_band = evidence_dead_band();
  // Only points with map evidence under both places count (scan_fit.hpp: paired_evidence): a point in a room the
  // map never observed must not make the mapped look-alike of that room the better place.
  for (std::size_t r = 0; r < h.size(); ++r) {
    const PairedEvidence paired =
        paired_evidence(point_log[r], observed[r], point_log[reference], observed[reference], dead_band);
    evidence[r] = (totals[reference] + paired.sum) / count;
  }
  {
    const ParticleArrays p = evaluator_.particles();
    const double to_plain = 1.0 / params_.sensor.weight_exponent;
    for (std::size_t i = 0; i < n; ++i) weights_[i] = prior_log_weight_[i] + to_plain * p.log_weight[i];
    const std::vector<double> with = group_log_sums(weights_.data(), group_.data(), n, h.size() + 1);
    const std::vector<double> without = group_log_sums(prior_log_weight_.data(), group_.data(), n, h.size() + 1);
    if (std::isfinite(with[h.size()]) && std::isfinite(without[h.size()])) {
      evidence[h.size()] = (with[h.size()] - without[h.size()]) / count;
    }
  }
  const double best = *std::max_element(evidence.begin(), evidence.end());
  // Until the belief first concentrates, no more than the tempering lets the particles count (a spread, global
  // belief: no early verdict between its modes); after, the tempering only keeps the particles of one tight mode
  // from degenerating and says nothing about how far apart two places are.
  const double per_point = step.tempering * params_.sensor.weight_exponent * count;
  const double scale = params_.hypothesis_evidence_points <= 0.0 ? per_point
                       : ever_concentrated_                      ? params_.hypothesis_evidence_points
                                            : std::min(params_.hypothesis_evidence_points, per_point);
  for (double& e : evidence) e = scale * (e - best);
  group_share_ = reweight_groups(prior_log_weight_.data(), post_log_weight_.data(), group_.data(), n, evidence);
  const double max =
      *std::max_element(post_log_weight_.begin(), post_log_weight_.begin() + static_cast<std::ptrdiff_t>(n));
  for (std::size_t i = 0; i < n; ++i) weights_[i] = std::exp(post_log_weight_[i] - max);
  step.ess = effective_sample_size(weights_.data(), n);

  // Hypotheses ranked by their tempered shares, each with its fit.
  std::vector<std::int32_t> rank(h.size());
  for (std::size_t r = 0; r < h.size(); ++r) {
    h[r].weight = group_share_[r];
    h[r].pose = refined[r];
    h[r].inlier_ratio = fits[r].inlier_ratio();
    h[r].coverage = fits[r].coverage();
    h[r].see_through_ratio = fits[r].see_through_ratio();
    rank[r] = static_cast<std::int32_t>(r);
  }
  std::stable_sort(rank.begin(), rank.end(), [&](std::int32_t a, std::int32_t b) {
    return h[static_cast<std::size_t>(a)].weight > h[static_cast<std::size_t>(b)].weight;
  });
  std::vector<Hypothesis> sorted;
  std::vector<std::int32_t> new_index(h.size() + 1, k);
  std::vector<double> shares(h.size() + 1, group_share_[h.size()]);
  for (std::size_t r = 0; r < rank.size(); ++r) {
    sorted.push_back(h[static_cast<std::size_t>(rank[r])]);
    new_index[static_cast<std::size_t>(rank[r])] = static_cast<std::int32_t>(r);
    shares[r] = group_share_[static_cast<std::size_t>(rank[r])];
  }
  for (std::size_t i = 0; i < n; ++i) group_[i] = new_index[static_cast<std::size_t>(group_[i])];
  top_log_.swap(point_log[static_cast<std::size_t>(rank[0])]);
  top_observed_.swap(observed[static_cast<std::size_t>(rank[0])]);
  group_share_ = shares;
  h = std::move(sorted);

  step.concentrated = take_dominant_hypothesis(estimate_, params_.estimate);
}

bool ParticleFilter::map_judges_track() const {
  constexpr double kMostOfTheScan = 0.75;
  return !(estimate_.coverage < std::max(params_.convergence.min_coverage, kMostOfTheScan));
}

double ParticleFilter::judged_ratio() const {
  if (trusted_track()) return estimate_.inlier_ratio;
  return std::isnan(estimate_.coverage) ? estimate_.inlier_ratio : estimate_.inlier_ratio * estimate_.coverage;
}

double ParticleFilter::evidence_dead_band() const {
  return 0.5 * static_cast<double>(params_.inlier_distance * params_.inlier_distance) /
         static_cast<double>(params_.sensor.sigma_hit * params_.sensor.sigma_hit);
}

void ParticleFilter::keep_track(const Pose& delta, double dt, const std::vector<Eigen::Vector3f>& points,
                                FilterStep& step) {
  if (!keeper_.active() || estimate_.hypotheses.empty()) return;
  const Hypothesis& top = estimate_.hypotheses.front();
  const Pose continuation = refine_pose(map_, keeper_.predict(delta), points);
  const ConvergenceOptions& c = params_.convergence;
  const bool continues = (top.pose.translation() - continuation.translation()).norm() <= c.max_jump_m &&
                         rotation_angle_between(top.pose.linear(), continuation.linear()) <= c.max_jump_rad;
  double evidence = 0.0;
  bool track_implausible = false;
  RayFit fit;
  if (!continues) {
    // The challenger (the dominant hypothesis) against the track's continuation, point by point on the points
    // both observe, in the units the hypotheses' shares move by (weigh_hypotheses).
    EndpointModel plain = params_.sensor;
    plain.weight_exponent = 1.0f;
    std::vector<double> log;
    const Eigen::Quaternionf q(Eigen::Quaterniond(continuation.linear()).cast<float>());
    point_log_likelihoods(map_, plain, continuation.translation().cast<float>(), q, points, log);
    std::vector<std::uint8_t> observed;
    fit = ray_fit(map_, continuation, points, params_.inlier_distance, 0.4f, &observed);
    const PairedEvidence e = paired_evidence(top_log_, top_observed_, log, observed, evidence_dead_band());
    evidence = params_.hypothesis_evidence_points * e.sum / static_cast<double>(points.size());
    track_implausible = params_.recovery_min_inliers > 0.0 && !(fit.coverage() < c.min_coverage) &&
                        fit.inlier_ratio() < params_.recovery_min_inliers;
  }
  const TrackKeeper::Decision d = keeper_.update(delta, continuation, continues, top.pose, evidence, track_implausible);
  step.challenge_evidence = keeper_.challenge_evidence();
  step.challenge_travel = keeper_.challenge_travel();
  if (d != TrackKeeper::Decision::kHold && d != TrackKeeper::Decision::kRestore) {
    track_covariance_ = top.covariance;
    return;
  }
  // Unproven: the estimate follows the track, carried by the odometry, its covariance growing by the motion
  // noise of each update (refined on the scan where the map has something to say).
  const MotionNoise noise = motion_noise(params_.motion, delta, dt);
  const double horizontal = static_cast<double>(noise.sigma_along) * noise.sigma_along +
                            static_cast<double>(noise.sigma_across) * noise.sigma_across;
  track_covariance_(0, 0) += horizontal;
  track_covariance_(1, 1) += horizontal;
  track_covariance_(2, 2) += static_cast<double>(noise.sigma_vertical) * noise.sigma_vertical;
  track_covariance_(3, 3) += static_cast<double>(noise.sigma_roll) * noise.sigma_roll;
  track_covariance_(4, 4) += static_cast<double>(noise.sigma_pitch) * noise.sigma_pitch;
  track_covariance_(5, 5) += static_cast<double>(noise.sigma_yaw) * noise.sigma_yaw;
  estimate_.pose = continuation;
  estimate_.covariance = track_covariance_;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> position(track_covariance_.topLeftCorner<3, 3>());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> rotation(track_covariance_.bottomRightCorner<3, 3>());
  estimate_.std_position = std::sqrt(std::max(position.eigenvalues().maxCoeff(), 0.0));
  estimate_.std_rotation = std::sqrt(std::max(rotation.eigenvalues().maxCoeff(), 0.0));
  estimate_.inlier_ratio = fit.inlier_ratio();
  estimate_.coverage = fit.coverage();
  estimate_.see_through_ratio = fit.see_through_ratio();
  step.holding = true;
  if (d == TrackKeeper::Decision::kRestore) restore_pending_ = true;
}

TrackState ParticleFilter::classify(const FilterStep& step) const {
  if (step.implausible || step.random_share > 1.0 - params_.estimate.converged_weight) return TrackState::kLost;
  if (estimate_.converged) return TrackState::kConverged;
  if (trusted_track() && estimate_.coverage < params_.convergence.min_coverage) return TrackState::kUnmapped;
  const std::vector<Hypothesis>& h = estimate_.hypotheses;
  if (step.holding || step.challenged || (h.size() >= 2 && h[1].weight >= params_.ambiguous_weight))
    return TrackState::kAmbiguous;
  return keeper_.active() ? TrackState::kTracking : TrackState::kSearching;
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

ParticleFilter::Injection ParticleFilter::plan_injection(double time, const FilterStep& step) const {
  Injection in;
  const std::size_t max = params_.kld.max_particles;
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
    in.count = std::min(max, std::max<std::size_t>(params_.hypothesis_min_particles, params_.kld.min_particles));
    in.candidates = in.count;
    in.share = 0.5;
    in.around = keeper_.pose();
  } else if (params_.challenger_candidates > 0 && ever_concentrated_ &&
             time - last_challenge_time_ >= params_.challenger_interval) {
    in.candidates = params_.challenger_candidates;
    in.count = std::max<std::size_t>(1, in.candidates / 200);
    // A tenth of a competitor's share: one scan that a challenger explains clearly better makes it one.
    in.share = params_.convergence.competitor_min_weight / 10.0;
  }
  return in;
}

void ParticleFilter::resample(std::size_t n, std::size_t budget, const Injection& injection,
                              const std::vector<Eigen::Vector3f>& points, FilterStep& step) {
  const std::size_t injected = std::min(injection.count, params_.kld.max_particles);
  if (injection.candidates > injected) reserve_search(injection.candidates);  // before any view is taken
  // Particle counts per group: each hypothesis heavy enough to keep at least hypothesis_min_particles, the rest
  // of the budget by share. Lighter hypotheses join the rest and take their chances.
  const std::size_t groups = group_share_.size();
  const std::size_t rest = groups - 1;
  std::vector<std::size_t> counts(groups, 0);
  std::vector<bool> kept_group(groups, false);
  double rest_share = group_share_[rest];
  for (std::size_t g = 0; g < rest; ++g) {
    if (group_share_[g] >= params_.hypothesis_min_weight) {
      kept_group[g] = true;
      counts[g] = std::max(params_.hypothesis_min_particles,
                           static_cast<std::size_t>(std::lround(group_share_[g] * static_cast<double>(budget))));
    } else {
      rest_share += group_share_[g];
    }
  }
  // Every credible hypothesis (one that could compete, convergence.hpp) gets as many particles as the largest:
  // with fewer, its mean sits a little off, its fit at its refined pose comes out a little worse, and the
  // evidence drifts towards whichever look-alike happened to hold more particles.
  std::size_t credible_count = 0;
  for (std::size_t g = 0; g < rest; ++g) {
    if (group_share_[g] >= params_.convergence.competitor_min_weight)
      credible_count = std::max(credible_count, counts[g]);
  }
  for (std::size_t g = 0; g < rest; ++g) {
    if (group_share_[g] >= params_.convergence.competitor_min_weight) counts[g] = credible_count;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!kept_group[static_cast<std::size_t>(group_[i])]) group_[i] = static_cast<std::int32_t>(rest);
  }
  double rest_weight = 0.0;
  for (std::size_t i = 0; i < n; ++i) rest_weight += group_[i] == static_cast<std::int32_t>(rest) ? weights_[i] : 0.0;
  counts[rest] =
      rest_weight > 0.0 ? static_cast<std::size_t>(std::lround(rest_share * static_cast<double>(budget))) : 0;
  // The challengers' pool: the places outside the heaviest hypotheses keep refining, however light.
  if (rest_weight > 0.0 && params_.challenger_candidates > 0 && ever_concentrated_) {
    counts[rest] = std::max(counts[rest], std::max<std::size_t>(1, params_.challenger_candidates / 200));
  }
  std::size_t kept = 0;
  for (std::size_t c : counts) kept += c;
  const std::size_t room = params_.kld.max_particles - injected;
  if (kept > room) {  // floors of many hypotheses over the cap: everyone shrinks alike
    const double scale = static_cast<double>(room) / static_cast<double>(kept);
    kept = 0;
    for (std::size_t& c : counts) kept += (c = static_cast<std::size_t>(std::floor(static_cast<double>(c) * scale)));
  }
  if (kept == 0) {  // rounding left nothing: keep the dominant hypothesis
    counts[kept_group[0] ? 0 : rest] = std::max<std::size_t>(1, std::min(room, budget));
    kept = counts[kept_group[0] ? 0 : rest];
  }

  Rng rng(params_.seed, 0x2E5A3Bull, step_);
  group_resampler_.resample(params_.resample_method, weights_.data(), group_.data(), n, counts, rng, ancestors_.data());
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
  if (injected > 0) {
    if (injection.around) {
      const ParticleArrays at{dst.x + kept,  dst.y + kept,  dst.z + kept,          dst.qw + kept,      dst.qx + kept,
                              dst.qy + kept, dst.qz + kept, dst.log_weight + kept, dst.capacity - kept};
      LocalInitSpread tight;
      tight.sigma_xy = 0.1;
      tight.sigma_z = 0.05;
      tight.sigma_yaw = 0.05;
      tight.sigma_roll_pitch = 0.02;
      sample_local(at, injected, *injection.around, tight, params_.seed, step_);
    } else if (injection.candidates > injected)
      search(injection.candidates, injected, points, dst, kept);
    else
      proposal().sample(dst, kept, kept + injected, params_.seed, step_);
  }
  // Each group's share is spread over its new particles. The injected particles carry the injection's share of
  // the belief, however many they are: many, to cover the map; a small share, while the evidence for a lost
  // track is weak (a correct track's fit dips now and then).
  const double injected_share = injected > 0 ? std::clamp(injection.share, 1e-9, 1.0 - 1e-6) : 0.0;
  std::size_t j = 0;
  for (std::size_t g = 0; g < groups; ++g) {
    const double share = g == rest ? rest_share : group_share_[g];
    const double log_w = std::log(std::max(share, 1e-300) / static_cast<double>(std::max<std::size_t>(counts[g], 1))) +
                         std::log1p(-injected_share);
    for (std::size_t c = 0; c < counts[g]; ++c) prior_log_weight_[j++] = log_w;
  }
  const double injected_log_w = injected > 0 ? std::log(injected_share / static_cast<double>(injected)) : 0.0;
  for (std::size_t i = kept; i < kept + injected; ++i) prior_log_weight_[i] = injected_log_w;
  evaluator_.swap_particles();
  injected_begin_ = kept;
  injected_end_ = kept + injected;
  count_ = kept + injected;
  updates_since_resample_ = 0;
  step.resampled = true;
}

double ParticleFilter::judge_fit(FilterStep& step) {
  // Absolute: once the belief has concentrated, a dominant hypothesis that explains too little of the scan
  // is wrong, however steady (a running average that started at a wrong lock would call it normal).
  // The ratio judged: over the points with map evidence while a track that was right carries on where the map
  // covers enough of the scan; where it covers too little (unmapped space) no verdict. Without such a track, over
  // all points: a place whose points fly out of the map is no better for it.
  ever_concentrated_ = ever_concentrated_ || step.concentrated;
  const bool covered = !(estimate_.coverage < params_.convergence.min_coverage);
  const double ratio = judged_ratio();
  const bool judged = !trusted_track() || map_judges_track();
  // A belief that is not a trusted track and whose scan the map hardly covers is off the map, not in an unmapped
  // room: a lost belief drifts there, where nothing speaks against it.
  const bool off_map = !trusted_track() && !covered;
  const bool implausible = params_.recovery_min_inliers > 0.0 && ever_concentrated_ && judged &&
                           (ratio < params_.recovery_min_inliers || off_map);
  implausible_streak_ = implausible ? implausible_streak_ + 1 : 0;
  step.implausible = implausible;
  if (implausible_streak_ < 2) return 0.0;
  const double share = std::clamp(1.0 - ratio / params_.recovery_min_inliers, 0.0, 1.0);
  return off_map ? std::max(share, 1.0 - estimate_.coverage / params_.convergence.min_coverage) : share;
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

WeightSummary ParticleFilter::weigh_scan(std::size_t n, const std::vector<Eigen::Vector3f>& points, FilterStep& step) {
  if (points.size() > points_capacity_) {
    points_capacity_ = points.size();
    evaluator_.reserve(capacity_, points_capacity_);
  }
  const Eigen::Quaternionf reference(Eigen::Quaterniond(last_estimate_pose_.linear()).cast<float>());
  UpdateTimings et;
  const WeightSummary summary = subset_first_.weigh(evaluator_, n, points, params_.sensor, reference, &et);
  step.timings.upload_ms = et.upload_ms;
  step.timings.weight_ms = et.evaluate_ms;
  step.timings.weight_gpu_ms = et.weight_gpu_ms;
  step.timings.reduce_gpu_ms = et.reduce_gpu_ms;
  return summary;
}

double ParticleFilter::weigh_evidence(std::size_t n, const std::vector<Eigen::Vector3f>& points,
                                      const WeightSummary& summary, FilterStep& step) {
  prepare_weights(n, step);
  weigh_hypotheses(n, points, step);
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
  // Recovery moving more of the belief elsewhere than converged_weight allows outside the dominant mode: lost.
  estimate_.converged = convergence_.update(estimate_, step.concentrated && !step.holding, delta,
                                            step.random_share > 1.0 - params_.estimate.converged_weight,
                                            challengers_weighed_ || params_.challenger_candidates == 0);
  step.challenged = convergence_.challenged(estimate_);
  // Trust is earned where the map covers the scan (converged at converged_min_coverage) and lost only where it
  // covers most of it: in a room the mapping run never entered the particles spread and `converged` lapses, which
  // on a scan at the edge of the coverage threshold must not turn the track into an off-map belief.
  if (estimate_.converged && !(estimate_.coverage < params_.convergence.min_coverage)) trusted_ = true;
  if (!estimate_.converged && map_judges_track()) trusted_ = false;
  if (!keeper_.active() && estimate_.converged) {
    keeper_.start(estimate_.pose);
    track_covariance_ = estimate_.covariance;
  }
  ever_converged_ = ever_converged_ || estimate_.converged;
  if (implausible_share > 0.0) {
    // A wrong lock: search again as after a global initialization (roughening, averages forgotten).
    keeper_.reset();
    ever_converged_ = false;
    recovery_.reset();
    convergence_.restart_after_wrong_lock();
    challengers_weighed_ = false;
    last_challenge_time_ = -1e300;
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
  Stopwatch t0;
  predict(n, delta, motion_.elapsed(time));
  step.timings.motion_ms = t0.ms();
  const WeightSummary summary = weigh_scan(n, points, step);

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
  ++step_;
  step.timings.total_ms = t_start.ms();
  return step;
}

}  // namespace tsdf_mcl
