// ParticleFilter's evidence and decision: tempered weights, the hypotheses and their paired evidence, the fit
// recovery and the implausible-fit test follow, the track keeper's turn and the state (particle_filter.hpp).
#include "tsdf_mcl/filter/particle_filter.hpp"

#include <algorithm>
#include <array>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "tsdf_mcl/core/stopwatch.hpp"
#include "tsdf_mcl/sensor/endpoint_kernel.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/hypothesis_weighting.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"
#include "tsdf_mcl/filter/scan_fit.hpp"
#include "tsdf_mcl/filter/tempering.hpp"

namespace tsdf_mcl {

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
  const Tempering t = temper(prior_log_weight_.data(), p.log_weight, n, target, weights_.data());
  const double beta = t.beta;
  for (std::size_t i = 0; i < n; ++i) post_log_weight_[i] = prior_log_weight_[i] + beta * p.log_weight[i];
  if (track_reweighed_) weigh_track_within(n, beta);
  step.tempering = beta;
  step.ess = t.ess;
}

namespace {

// Each hypothesis's place: its pose refined onto the map, its points' log-likelihoods there and their map evidence.
struct Places {
  std::vector<Pose> pose;
  std::vector<double> total;  // the points' log-likelihoods summed
  std::vector<std::vector<double>> point_log;
  std::vector<std::vector<std::uint8_t>> observed;
  std::vector<RayFit> fit;
  std::size_t reference = 0;  // the best-fitting place
};

// Each group's k heaviest particles (by weight, heaviest first, ties by index; fewer where a group has fewer). One pass
// that keeps each group's k best so far: every update runs it over all particles, and k is small.
std::vector<std::vector<std::size_t>> heaviest_particles(const std::int32_t* group, const double* w, std::size_t n,
                                                         std::size_t groups, std::size_t k) {
  const auto heavier = [&](std::size_t a, std::size_t b) { return w[a] > w[b] || (w[a] == w[b] && a < b); };
  std::vector<std::vector<std::size_t>> best(groups);
  for (std::size_t i = 0; i < n; ++i) {
    const auto g = static_cast<std::size_t>(group[i]);
    if (g >= groups || k == 0) continue;
    std::vector<std::size_t>& b = best[g];
    if (b.size() == k && !heavier(i, b.back())) continue;
    b.insert(std::upper_bound(b.begin(), b.end(), i, heavier), i);
    if (b.size() > k) b.pop_back();
  }
  return best;
}

// Whether each point, seen from `pose`, ends in a voxel the map observed.
void known_endpoints(const TsdfMap& map, const Pose& pose, const std::vector<Eigen::Vector3f>& points,
                     std::vector<std::uint8_t>& known) {
  const kernel::MapView view(map);
  const Eigen::Matrix3f r = pose.linear().cast<float>();
  const Eigen::Vector3f t = pose.translation().cast<float>();
  known.resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f g = (r * points[i] + t) * view.inv_voxel;
    const float at[3] = {g.x(), g.y(), g.z()};
    known[i] = kernel::sample_nearest(view, at) != TsdfMap::kUnknownValue ? 1 : 0;
  }
}

// Refines every hypothesis onto the map from its mean pose and from its heaviest particle: a mode's mean sits off
// its place while the mode is spread (a robot turning on the spot spreads its yaw), and a few Gauss-Newton steps
// from there may not reach the place; judged at such a pose, the right room loses to its look-alike in one scan.
// The better start wins, judged on the points that end in observed space at both (ties: the mean).
Places refine_places(const TsdfMap& map, const std::vector<Hypothesis>& h, const ParticleArrays& particles,
                     const std::vector<std::vector<std::size_t>>& particle_starts,
                     const std::vector<Eigen::Vector3f>& points, const EndpointModel& plain, float inlier_distance,
                     float frontier_reach, double dead_band, const std::function<WallTilt(const Pose&)>& walls_at) {
  struct Start {
    std::size_t hypothesis;
    Pose pose;
    double total;
    std::vector<double> log;
    WallTilt walls;
    std::vector<std::uint8_t> known;  // the point ends in a voxel the map observed
  };
  constexpr double kNone = -std::numeric_limits<double>::infinity();
  std::vector<Start> starts;
  for (std::size_t r = 0; r < h.size(); ++r) {
    starts.push_back(Start{r, h[r].pose, kNone, {}, walls_at(h[r].pose), {}});
    for (const std::size_t i : particle_starts[r]) {
      Pose start = Pose::Identity();
      start.linear() = particles.rotation(i).cast<double>().normalized().toRotationMatrix();
      start.translation() = particles.position(i).cast<double>();
      starts.push_back(Start{r, start, kNone, {}, walls_at(start), {}});
    }
  }
  // The refinements are independent (the map is read-only): one per thread and start, so that eight hypotheses
  // of two starts each keep sixteen cores busy.
#pragma omp parallel for schedule(dynamic)
  for (std::ptrdiff_t ss = 0; ss < static_cast<std::ptrdiff_t>(starts.size()); ++ss) {
    Start& s = starts[static_cast<std::size_t>(ss)];
    s.pose = refine_pose(map, s.pose, points, 6, &s.walls);
    const Eigen::Quaternionf q(Eigen::Quaterniond(s.pose.linear()).cast<float>());
    point_log_likelihoods(map, plain, s.pose.translation().cast<float>(), q, points, s.log);
    s.total = 0.0;
    for (double l : s.log) s.total += l;
    known_endpoints(map, s.pose, points, s.known);
  }
  Places places;
  places.pose.resize(h.size());
  places.total.assign(h.size(), kNone);
  places.point_log.resize(h.size());
  places.observed.resize(h.size());
  places.fit.resize(h.size());
  // Not on the whole scan's total: it counts a point in space the map never observed as a miss, so it rewarded the
  // start that moves the scan into the mapped part. A drone above the band of the office that a ground robot mapped
  // had its place named by a particle 1.2 m too low, and the belief followed (with kTrackRadius, which keeps such
  // particles off the whole scan's weights: ChangedMap.TheHeightHoldsWhateverTheWallsWeigh).
  std::vector<std::size_t> chosen(h.size(), starts.size());
  for (std::size_t k = 0; k < starts.size(); ++k) {
    std::size_t& c = chosen[starts[k].hypothesis];
    if (c == starts.size()) {
      c = k;
      continue;
    }
    const PairedEvidence e = paired_evidence(starts[k].log, starts[k].known, starts[c].log, starts[c].known, dead_band);
    if (e.sum > 0.0) c = k;
  }
  for (std::size_t r = 0; r < h.size(); ++r) {
    Start& s = starts[chosen[r]];
    places.total[r] = s.total;
    places.pose[r] = s.pose;
    places.point_log[r].swap(s.log);
  }
#pragma omp parallel for schedule(dynamic)
  for (std::ptrdiff_t rr = 0; rr < static_cast<std::ptrdiff_t>(h.size()); ++rr) {
    const auto r = static_cast<std::size_t>(rr);
    places.fit[r] = ray_fit(map, places.pose[r], points, inlier_distance, kSeeThroughMargin, &places.observed[r]);
    if (frontier_reach > 0.0f) drop_frontier_points(map, places.pose[r], points, frontier_reach, places.observed[r]);
  }
  for (std::size_t r = 0; r < h.size(); ++r) {
    if (places.total[r] > places.total[places.reference]) places.reference = r;
  }
  return places;
}

// What a verdict between the places rests on: each one's spread and its fit at its refined pose.
std::vector<PlaceJudgement> place_judgements(const std::vector<Hypothesis>& h, const std::vector<RayFit>& fit,
                                             const std::vector<bool>& waits, const PoseEstimateOptions& options) {
  std::vector<PlaceJudgement> judged(h.size());
  for (std::size_t r = 0; r < h.size(); ++r) {
    judged[r] = PlaceJudgement{compact(h[r], options), waits[r], fit[r].coverage(), fit[r].inlier_ratio()};
  }
  return judged;
}

}  // namespace

void ParticleFilter::weigh_hypotheses(std::size_t n, const std::vector<Eigen::Vector3f>& points, FilterStep& step) {
  estimate_ = estimator_.estimate(evaluator_.particles(), weights_.data(), n);
  std::vector<Hypothesis>& h = estimate_.hypotheses;
  const auto rest = static_cast<std::int32_t>(h.size());  // the group of the particles in no hypothesis
  for (std::size_t i = 0; i < n; ++i) {
    const std::int32_t g = estimator_.hypothesis_of(i);
    group_[i] = g >= 0 ? g : rest;
  }
  // Each hypothesis's evidence: the mean log-likelihood per point at its mean pose refined onto the map (the
  // place's fit, not its particles' alignment); the refined pose is the hypothesis's estimate. The rest
  // (lighter modes, challengers, stray particles) have no one pose: theirs is their marginal likelihood per
  // point. A scan counts as hypothesis_evidence_points independent points, or as few as the tempering lets the
  // particles count it while that is fewer (a spread, global belief: no early verdict between its modes).
  EndpointModel plain = params_.sensor;
  plain.weight_exponent = 1.0f;
  const auto count = static_cast<double>(points.size());
  // Each place refined from its mean and its heaviest particle; once the places are named and until the belief first
  // concentrates, a compact place that fits clearly worse than the best one again from its kRefineStarts heaviest
  // particles. In the two-storey runs a mode's mean sat 0.1 m above the true height, and on single updates both starts
  // settled 0.12 m high and tilted 2 degrees (rays through the floor, inliers 0.92-0.96 against the other storey's
  // 0.98-0.99): each such update took the true storey's share down, and on two in a row a decisive view turned a
  // 0.61 lead into 0.41 a hundred scans before the staircase came into view. Not while the search's modes are still
  // spread: there the luck of which mode held a well-placed particle decided between the symmetric building's wings.
  const std::vector<std::vector<std::size_t>> heaviest =
      heaviest_particles(group_.data(), weights_.data(), n, h.size(), kRefineStarts);
  std::vector<std::vector<std::size_t>> starts(h.size());
  for (std::size_t r = 0; r < h.size(); ++r) {
    if (!heaviest[r].empty()) starts[r].push_back(heaviest[r].front());
  }
  const auto refine = [&] {
    return refine_places(map_, h, evaluator_.particles(), starts, points, plain, params_.inlier_distance,
                         frontier_reach(), evidence_dead_band(), [this](const Pose& pose) { return walls_at(pose); });
  };
  Places places = refine();
  if (places_named_ && !ever_concentrated_) {
    double best_inliers = 0.0;
    for (const RayFit& f : places.fit) best_inliers = std::max(best_inliers, f.inlier_ratio());
    bool again = false;
    for (std::size_t r = 0; r < h.size(); ++r) {
      if (h[r].weight < params_.hypothesis_min_weight || !compact(h[r], params_.estimate) ||
          best_inliers - places.fit[r].inlier_ratio() < kRefineAgainGap)
        continue;
      starts[r] = heaviest[r];
      again = true;
    }
    if (again) places = refine();
  }
  // Between places, only the points that one place explains and the other does not are evidence: each point's
  // log-likelihood difference to the best-fitting hypothesis counts beyond a dead band of what a point
  // inlier_distance off a surface loses. Two look-alike rooms differ in every point by the few millimetres
  // and tenths of a degree by which their refined poses happen to differ; summed over hundreds of points and
  // scans, those differences were a random walk that decided between identical places (within a few hundred
  // scans in the symmetric test building). A feature only one of them has (a cabinet) still moves its points by
  // the whole hit-versus-miss ratio of the model.
  // Only points with map evidence under both places count (scan_fit.hpp: paired_evidence): a point in a room the
  // map never observed must not make the mapped look-alike of that room the better place.
  // And where a place that fits its observed points well lies mostly in space the map never observed, after the
  // belief has followed a place the map covers (mapped_track_), the pair's evidence waits: what the map observes
  // there is the frontier of a room the mapping run skipped (surfaces seen once, at grazing angles, through a
  // door), which fits any scan worse than a mapped look-alike does, whatever the place. The shares stay as they
  // were until the map covers most of the scan at both places again. (A place that lies mostly off the map from
  // the start, or that fits its observed points badly, is judged as before: a global search must still drop it.)
  // The continuation of the kept track is exempt from the fit condition: crossing the doorway into a skipped room,
  // its observed points are the frontier's worst (inliers 0.73 in ChangedMap.TheTrackHoldsPastTheFrontierOf...).
  const double dead_band = evidence_dead_band();
  const std::size_t ref = places.reference;
  // A waiting place takes the best evidence of the places judged (place_evidence), not the reference's: in the
  // symmetric building a third place held the best total, the mirror wing beat it by 54 nats, and the right track,
  // at the frontier and tied with that third place, fell from 0.96 to 0.50 of the belief in two updates.
  // A pair waits too where the map covers kFrontierCoverageGap less of the scan at one of two look-alikes that both fit
  // as a frontier does (waiting_pairs): in the symmetric-skip runs, as the skipped room's door came into view, the true
  // wing lost 0.05 of the belief to the mapped twin while its coverage fell from 0.94 to 0.78, enough to move an
  // estimate 18 m.
  std::vector<FrontierView> views(h.size());
  for (std::size_t r = 0; r < h.size(); ++r) {
    const bool near = (places.pose[r].translation() - places.pose[ref].translation()).norm() <= kTrackRadius;
    views[r] = FrontierView{places.fit[r].coverage(), at_frontier_of(places.fit[r], places.pose[r]), near};
  }
  const std::vector<bool> waits = waiting_pairs(views, ref, kMostOfTheScan, kFrontierCoverageGap);
  std::vector<double> paired(h.size(), 0.0);
  for (std::size_t r = 0; r < h.size(); ++r) {
    paired[r] =
        paired_evidence(places.point_log[r], places.observed[r], places.point_log[ref], places.observed[ref], dead_band)
            .sum;
  }
  std::vector<double> evidence = place_evidence(places.total[ref], paired, waits, count);
  evidence.push_back(0.0);  // the rest's
  // The rest has no place to pair its points with: its marginal likelihood counts the points in unobserved space
  // as misses. While the dominant place is at the frontier of unmapped space, that measure would hand its share to
  // stray particles and fresh challengers at mapped places (a drone above the mapped band of a ground robot's map:
  // 57 % in one update, and the next update, the belief no longer concentrated, weighed its track on the whole scan
  // and sank it 0.8 m). Like a pair's evidence there, theirs waits: no more than the best place's.
  const double rest_per_point = rest_evidence(n, h.size() + 1, count);
  if (!std::isnan(rest_per_point)) {
    evidence[h.size()] = !h.empty() && at_frontier(places.fit[0], places.pose[0])
                             ? std::min(rest_per_point, places.total[ref] / count)
                             : rest_per_point;
  }
  const double best = *std::max_element(evidence.begin(), evidence.end());
  // Until the belief first concentrates, no more than the tempering lets the particles count (a spread, global
  // belief: no early verdict between its modes); after, the tempering only keeps the particles of one tight mode
  // from degenerating and says nothing about how far apart two places are.
  const double per_point = step.tempering * params_.sensor.weight_exponent * count;
  const double scale = params_.hypothesis_evidence_points <= 0.0 ? per_point
                       : ever_concentrated_                      ? params_.hypothesis_evidence_points
                                            : std::min(params_.hypothesis_evidence_points, per_point);
  std::vector<double> nats(evidence.size());
  for (std::size_t k = 0; k < evidence.size(); ++k) nats[k] = scale * (evidence[k] - best);
  // As the places are named, tied ones start equal (FilterParameters::even_tied_places); before the first
  // concentration a decisive view still turns the belief (FilterParameters::decisive_inlier_gap).
  even_places_as_named(n, h, places.fit, waits, nats);
  turn_on_decisive_views(n, h, places.pose, places.fit, evidence, waits, nats);
  group_share_ = reweight_groups(prior_log_weight_.data(), post_log_weight_.data(), group_.data(), n, nats);
  const double max =
      *std::max_element(post_log_weight_.begin(), post_log_weight_.begin() + static_cast<std::ptrdiff_t>(n));
  for (std::size_t i = 0; i < n; ++i) weights_[i] = std::exp(post_log_weight_[i] - max);
  step.ess = effective_sample_size(weights_.data(), n);

  for (std::size_t r = 0; r < h.size(); ++r) {
    h[r].weight = group_share_[r];
    h[r].pose = places.pose[r];
    h[r].inlier_ratio = places.fit[r].inlier_ratio();
    h[r].coverage = places.fit[r].coverage();
    h[r].see_through_ratio = places.fit[r].see_through_ratio();
  }
  double compact_share = 0.0;
  for (const Hypothesis& x : h) compact_share += compact(x, params_.estimate) ? x.weight : 0.0;
  places_named_ = places_named_ || compact_share >= params_.estimate.converged_weight;
  rank_hypotheses(n, h, places.point_log, places.observed, rest);
  covered_streak_ = h.front().coverage >= kMostOfTheScan ? covered_streak_ + 1 : 0;
  mapped_track_ = mapped_track_ || covered_streak_ >= kMappedTrackUpdates;
  step.concentrated = take_dominant_hypothesis(estimate_, params_.estimate);
  dominant_concentrated_ = step.concentrated;
  keep_estimate_place(step);
}

void ParticleFilter::even_places_as_named(std::size_t n, const std::vector<Hypothesis>& h,
                                          const std::vector<RayFit>& fit, const std::vector<bool>& waits,
                                          std::vector<double>& nats) {
  // A local start's place is the operator's; once the belief has concentrated, its shares are evidence.
  if (!params_.even_tied_places || places_named_ || ever_concentrated_ || local_start_ ||
      params_.hypothesis_evidence_points <= 0.0)
    return;
  even_tied_places(place_judgements(h, fit, waits, params_.estimate), params_.decisive_inlier_gap, kNearlyAllOfTheScan,
                   group_log_sums(prior_log_weight_.data(), group_.data(), n, nats.size()), nats);
}

void ParticleFilter::turn_on_decisive_views(std::size_t n, const std::vector<Hypothesis>& h,
                                            const std::vector<Pose>& poses, const std::vector<RayFit>& fit,
                                            const std::vector<double>& evidence, const std::vector<bool>& waits,
                                            std::vector<double>& nats) {
  std::vector<std::pair<Pose, Pose>> decisive;
  if (!ever_concentrated_ && params_.hypothesis_evidence_points > 0.0) {
    std::size_t b = h.size();
    const std::vector<std::size_t> beaten =
        decisively_beaten(place_judgements(h, fit, waits, params_.estimate), evidence, params_.decisive_inlier_gap,
                          kNearlyAllOfTheScan, b);
    // Only a verdict the last update gave as well, between the same two places carried by the odometry: a place whose
    // refined pose landed off for one update (rays through surfaces, 0.05 fewer inliers) loses a single update's
    // verdict, and in the two-storey runs such single updates turned the belief between the storeys long before the
    // staircase came into view.
    const auto same = [&](const Pose& before, const Pose& now) {
      return params_.convergence.same_place(before * update_delta_, now);
    };
    std::vector<std::size_t> repeated;
    for (const std::size_t r : beaten) {
      decisive.emplace_back(poses[b], poses[r]);
      for (const auto& [best, worse] : decisive_before_) {
        if (same(best, poses[b]) && same(worse, poses[r])) {
          repeated.push_back(r);
          break;
        }
      }
    }
    if (!repeated.empty()) {
      turn_odds(b, repeated, evidence, group_log_sums(prior_log_weight_.data(), group_.data(), n, evidence.size()),
                params_.hypothesis_evidence_points, 2.0 * std::log(params_.estimate_switch_ratio), nats);
    }
  }
  decisive_before_.swap(decisive);
}

void ParticleFilter::keep_estimate_place(const FilterStep& step) {
  const std::vector<Hypothesis>& h = estimate_.hypotheses;
  if (step.concentrated || !estimate_prediction_ || params_.estimate.best_particle) return;
  const ConvergenceOptions& c = params_.convergence;
  const std::size_t k =
      estimate_place(h, *estimate_prediction_, params_.estimate_switch_ratio, c.max_jump_m, c.max_jump_rad);
  if (k != 0) take_hypothesis(estimate_, k, params_.estimate);
}

bool ParticleFilter::at_frontier(const RayFit& fit, const Pose& pose) const {
  return fit.coverage() < kMostOfTheScan && at_frontier_of(fit, pose);
}

bool ParticleFilter::at_frontier_of(const RayFit& fit, const Pose& pose) const {
  if (!mapped_track_) return false;
  if (fit.inlier_ratio() >= kFrontierMinInliers) return true;
  return track_prediction_ && params_.convergence.same_place(pose, *track_prediction_);
}

double ParticleFilter::rest_evidence(std::size_t n, std::size_t groups, double points) {
  const ParticleArrays p = evaluator_.particles();
  const double to_plain = 1.0 / params_.sensor.weight_exponent;
  for (std::size_t i = 0; i < n; ++i) weights_[i] = prior_log_weight_[i] + to_plain * p.log_weight[i];
  const std::vector<double> with = group_log_sums(weights_.data(), group_.data(), n, groups);
  const std::vector<double> without = group_log_sums(prior_log_weight_.data(), group_.data(), n, groups);
  const std::size_t rest = groups - 1;
  if (!std::isfinite(with[rest]) || !std::isfinite(without[rest])) return std::numeric_limits<double>::quiet_NaN();
  return (with[rest] - without[rest]) / points;
}

void ParticleFilter::rank_hypotheses(std::size_t n, std::vector<Hypothesis>& h,
                                     std::vector<std::vector<double>>& point_log,
                                     std::vector<std::vector<std::uint8_t>>& observed, std::int32_t rest_group) {
  std::vector<std::int32_t> rank(h.size());
  for (std::size_t r = 0; r < h.size(); ++r) rank[r] = static_cast<std::int32_t>(r);
  std::stable_sort(rank.begin(), rank.end(), [&](std::int32_t a, std::int32_t b) {
    return h[static_cast<std::size_t>(a)].weight > h[static_cast<std::size_t>(b)].weight;
  });
  std::vector<Hypothesis> sorted;
  std::vector<std::int32_t> new_index(h.size() + 1, rest_group);
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
}

bool ParticleFilter::map_judges_track() const {
  return !(estimate_.coverage < std::max(params_.convergence.min_coverage, kMostOfTheScan));
}

double ParticleFilter::judged_ratio() const {
  if (trusted_track()) return estimate_.inlier_ratio;
  return explained_share(estimate_.inlier_ratio, estimate_.coverage);
}

float ParticleFilter::frontier_reach() const {
  // Only once the belief has followed a place the map covers (mapped_track_): a global search's first updates
  // need every point to tell places apart, and dropping the frontier's there delayed the first right estimate by
  // 1-3 s in the avz building (open to the sky, so every wall top is a frontier).
  return params_.frontier_evidence || !mapped_track_ ? 0.0f : map_.truncation();
}

std::vector<Pose> ParticleFilter::evidence_centres(const Pose& delta, double reach) const {
  // Once there is a track to keep: the last update's dominant hypothesis held the belief, concentrated, or the filter
  // has converged since its (re)start. A global search before that is weighed on the whole scan: it needs every point
  // to tell places apart, and weighing its places on their own points tipped which of a symmetric building's two wings
  // led (symmetric VLP-16 handheld-1: 0.958 -> 0.228 localized, the wrong wing ahead from 1.6 s on).
  std::vector<Pose> centres;
  if (!dominant_concentrated_ && !ever_converged_) {
    // A local start names its place: the track to keep is there from the first update, spread as the start was.
    // Weighed on the whole scan, whose unobserved points count as misses, a drone's start whose map a ground robot
    // made (ChangedMap.*KeepsItsHeight) went 0.1-0.2 m down for 11 of its 12 updates on the ground: a lower pose
    // puts the walls' points above the mapped band onto it.
    if (local_start_) centres.push_back(last_estimate_pose_ * delta);
    return centres;
  }
  // The belief as a few compact places: each hypothesis that passes the convergence test's spread (and is spread less
  // than `reach`), and the estimate's own (the kept track, which the estimate follows while a challenger is unproven,
  // may hold a sliver of the belief). Each is weighed on its own points, a look-alike that draws belief from the track
  // too: weighing the dominant place's alone stopped while the look-alike held a fifth or more, and a drone's track in
  // the avz building sank 0.25 m. A place spread wider takes the whole scan, which draws it together again (weighed
  // on a third of balm's scan up to `reach`, the tracked cloud stayed wide: KLD-sampling kept a median of 4,400
  // particles, where 3,400 followed the cloud otherwise).
  const double spread = std::min(reach, params_.estimate.converged_std_xyz);
  const auto within_spread = [&](double std_position, double std_rotation) {
    return std_position <= spread && std_rotation <= params_.estimate.converged_std_angle;
  };
  const auto add = [&](const Pose& pose) {
    for (const Pose& c : centres) {
      if ((c.translation() - pose.translation()).norm() <= kTrackRadius) return;
    }
    centres.push_back(pose);
  };
  double compact_weight = 0.0;
  if (within_spread(estimate_.std_position, estimate_.std_rotation)) add(last_estimate_pose_ * delta);
  for (const Hypothesis& h : estimate_.hypotheses) {
    if (centres.size() >= kMaxEvidencePlaces) break;
    if (!within_spread(h.std_position, h.std_rotation)) continue;
    compact_weight += h.weight;
    add(h.pose * delta);
  }
  // A belief spread wider than those places is weighed on the whole scan (and too large to weigh twice).
  if (compact_weight < params_.estimate.converged_weight) centres.clear();
  return centres;
}

void ParticleFilter::weigh_track_on_evidence(std::size_t n, const std::vector<Eigen::Vector3f>& points,
                                             const Pose& delta, FilterStep& step) {
  track_reweighed_ = false;
  places_reweighed_ = 0;
  if (params_.frontier_evidence) return;
  // Places spread less than a truncation length: a point a truncation length clear of unobserved space at a place's
  // predicted pose stays clear of it under each of its particles that matter, and one at the frontier is dropped for
  // all. (Wider reaches probe past the surfaces' bands into the unknown inside walls: in a fully mapped building a
  // reach of truncation + 2 sigma dropped half of a scan.)
  const float reach = map_.truncation();
  const std::vector<Pose> centres = evidence_centres(delta, static_cast<double>(reach));
  if (centres.empty()) return;
  const ParticleArrays p = evaluator_.particles();
  place_of_.assign(n, -1);
  const auto near = static_cast<float>(kTrackRadius);
  for (std::size_t c = 0; c < centres.size(); ++c) {
    const RayFit centre_fit =
        ray_fit(map_, centres[c], points, params_.inlier_distance, kSeeThroughMargin, &evidence_observed_);
    const double below_coverage =
        params_.see_through_weight > 0.0 ? coverage_below_horizon(centres[c], points, evidence_observed_) : 0.0;
    const std::size_t dropped = drop_frontier_points(map_, centres[c], points, reach, evidence_observed_);
    std::size_t unobserved = 0;
    for (const std::uint8_t o : evidence_observed_) unobserved += o ? 0 : 1;
    // Nothing to drop (the place's whole scan is evidence), or too little left to weigh on (deep in a room the
    // mapping run never entered): the whole scan.
    if (dropped == 0 && unobserved == 0) continue;
    if (points.size() - unobserved < std::max<std::size_t>(kMinEvidencePoints, points.size() / 8)) continue;
    evidence_points_.clear();
    for (std::size_t j = 0; j < points.size(); ++j) {
      if (evidence_observed_[j]) evidence_points_.push_back(points[j]);
    }
    // The place's particles (not already another's), gathered into the spare set and weighed on its points.
    members_.clear();
    const Eigen::Vector3f centre = centres[c].translation().cast<float>();
    for (std::size_t i = 0; i < n; ++i) {
      if (place_of_[i] < 0 && (Eigen::Vector3f(p.x[i], p.y[i], p.z[i]) - centre).norm() <= near) {
        members_.push_back(static_cast<std::uint32_t>(i));
      }
    }
    if (members_.empty()) continue;
    const ParticleArrays spare = evaluator_.spare_particles();
    for (std::size_t j = 0; j < members_.size(); ++j) spare.set(j, p.position(members_[j]), p.rotation(members_[j]));
    evaluator_.swap_particles();
    try {
      evaluator_.set_points(evidence_points_);
      evaluator_.weigh(members_.size(), params_.sensor);
    } catch (...) {
      evaluator_.swap_particles();
      throw;
    }
    evaluator_.swap_particles();
    const UpdateTimings& t = evaluator_.last_timings();
    step.timings.weight_ms += t.evaluate_ms;
    step.timings.weight_gpu_ms += t.weight_gpu_ms;
    evidence_log_weight_.resize(n);
    for (std::size_t j = 0; j < members_.size(); ++j) {
      place_of_[members_[j]] = static_cast<std::int32_t>(c);
      evidence_log_weight_[members_[j]] = spare.log_weight[j];
    }
    weigh_height_on_rays(centres[c], points, centre_fit, below_coverage);
    places_reweighed_ = c + 1;
    track_reweighed_ = true;
    // The report's figure: the first place weighed so, the estimate's where it was.
    if (step.weighed_points == 0) step.weighed_points = evidence_points_.size();
  }
}

double ParticleFilter::coverage_below_horizon(const Pose& centre, const std::vector<Eigen::Vector3f>& points,
                                              const std::vector<std::uint8_t>& observed) {
  const Eigen::Vector3f up_in_sensor =
      (centre.linear().transpose() * proposal().map_up().cast<double>()).cast<float>().normalized();
  std::size_t below = 0, seen = 0;
  for (std::size_t j = 0; j < points.size() && j < observed.size(); ++j) {
    if (points[j].dot(up_in_sensor) >= 0.0f) continue;
    ++below;
    seen += observed[j] ? 1 : 0;
  }
  return below ? static_cast<double>(seen) / static_cast<double>(below) : 0.0;
}

void ParticleFilter::weigh_height_on_rays(const Pose& centre, const std::vector<Eigen::Vector3f>& points,
                                          const RayFit& centre_fit, double below_coverage) {
  // Only where the map holds most of what the sensor sees below its horizon (the floor and what stands on it), whose
  // surfaces the lowered rays pass through. Deep in a room the mapping run skipped, the rays meet the map's residue
  // there instead (walls held from the next room, furniture that grazing rays carved free): 0-6 of 512 see through
  // at any height, and that noise moved the height of avz-skip's VLP-16 drone 0.2-0.3 m. The points above the
  // horizon do not count: those above the walls' mapped band are what leaves the height to the rays.
  if (!(params_.see_through_weight > 0.0) || below_coverage < kMostOfTheScan) return;
  // And only at a place that fits the scan as a track that may converge does (converged_min_inliers). At a wrong
  // place the rays see through at every height; weighed, they moved its particles to the height that fits least
  // badly, and a kidnapped track's fit no longer looked implausible enough to start the search again
  // (Kidnapping.FilterRecoversWithoutARestart: no search in 30 updates).
  if (centre_fit.inlier_ratio() < params_.convergence.min_inlier_ratio) return;
  // The rays' see-through (ray_fit) at the place's pose shifted along the map's up axis by up to a truncation length
  // in thirds: off in height, rays that end on a mapped surface at the true pose (the floor, what stands on it, a
  // mapped ceiling) pass into it before they end. The points clear of the frontier cannot tell heights apart where the
  // map saw the walls only up to a band (they favour whichever pose picked them: docs/filter.md, "Why the avz
  // handheld's height stayed low"); the rays can. Each particle takes the count at its own height (linear between the
  // steps, the ends held).
  constexpr int kSteps = 3;
  const Eigen::Vector3d up = proposal().map_up().cast<double>().normalized();
  const double step = static_cast<double>(map_.truncation()) / kSteps;
  std::array<double, 2 * kSteps + 1> see{};
  see[kSteps] = static_cast<double>(centre_fit.see_through);
#pragma omp parallel for schedule(static)
  for (int k = -kSteps; k <= kSteps; ++k) {
    if (k == 0) continue;
    Pose shifted = centre;
    shifted.translation() += up * (k * step);
    see[static_cast<std::size_t>(k + kSteps)] =
        static_cast<double>(ray_fit(map_, shifted, points, params_.inlier_distance, kSeeThroughMargin).see_through);
  }
  // A ray through a surface costs what a point far from every surface costs against one on it, tempered like the
  // points (the sensor model's exponent; the update's tempering applies to both in weigh_track_within).
  const EndpointModel& m = params_.sensor;
  const double per_ray = params_.see_through_weight * static_cast<double>(m.weight_exponent) *
                         std::log((m.hit_scale() + m.p_rand()) / m.p_rand());
  const ParticleArrays p = evaluator_.particles();
  for (const std::uint32_t i : members_) {
    const double offset = (Eigen::Vector3d(p.x[i], p.y[i], p.z[i]) - centre.translation()).dot(up) / step;
    const double u = std::clamp(offset, -static_cast<double>(kSteps), static_cast<double>(kSteps)) + kSteps;
    const auto k = static_cast<std::size_t>(std::min(std::floor(u), 2.0 * kSteps - 1.0));
    const double f = u - static_cast<double>(k);
    evidence_log_weight_[i] -= per_ray * ((1.0 - f) * see[k] + f * see[k + 1]);
  }
}

void ParticleFilter::weigh_track_within(std::size_t n, double beta) {
  // Each place's posterior log-weights with its evidence points' likelihood, shifted so that their log-sum-exp (the
  // place's weight against every other) stays what the whole scan gave.
  for (std::size_t c = 0; c < places_reweighed_; ++c) {
    double max_scan = -std::numeric_limits<double>::infinity();
    double max_evidence = -std::numeric_limits<double>::infinity();
    const auto place = static_cast<std::int32_t>(c);
    for (std::size_t i = 0; i < n; ++i) {
      if (place_of_[i] != place) continue;
      evidence_log_weight_[i] = prior_log_weight_[i] + beta * evidence_log_weight_[i];
      max_scan = std::max(max_scan, post_log_weight_[i]);
      max_evidence = std::max(max_evidence, evidence_log_weight_[i]);
    }
    if (!std::isfinite(max_scan)) continue;  // the whole scan weighed this place
    double sum_scan = 0.0;
    double sum_evidence = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (place_of_[i] != place) continue;
      sum_scan += std::exp(post_log_weight_[i] - max_scan);
      sum_evidence += std::exp(evidence_log_weight_[i] - max_evidence);
    }
    const double shift = (max_scan + std::log(sum_scan)) - (max_evidence + std::log(sum_evidence));
    for (std::size_t i = 0; i < n; ++i) {
      if (place_of_[i] == place) post_log_weight_[i] = evidence_log_weight_[i] + shift;
    }
  }
  const double max =
      *std::max_element(post_log_weight_.begin(), post_log_weight_.begin() + static_cast<std::ptrdiff_t>(n));
  for (std::size_t i = 0; i < n; ++i) weights_[i] = std::exp(post_log_weight_[i] - max);
}

double ParticleFilter::evidence_dead_band() const {
  return 0.5 * static_cast<double>(params_.inlier_distance * params_.inlier_distance) /
         static_cast<double>(params_.sensor.sigma_hit * params_.sensor.sigma_hit);
}

void ParticleFilter::keep_track(const Pose& delta, double dt, const std::vector<Eigen::Vector3f>& points,
                                FilterStep& step) {
  track_followed_ = false;
  if (!keeper_.active() || estimate_.hypotheses.empty()) return;
  const Hypothesis& top = estimate_.hypotheses.front();
  const Pose predicted = keeper_.predict(delta);
  const WallTilt walls = walls_at(predicted);
  const Pose continuation = refine_pose(map_, predicted, points, 6, &walls);
  const ConvergenceOptions& c = params_.convergence;
  const bool continues = c.same_place(top.pose, continuation);
  track_followed_ = continues;
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
    fit = ray_fit(map_, continuation, points, params_.inlier_distance, kSeeThroughMargin, &observed);
    if (frontier_reach() > 0.0f) drop_frontier_points(map_, continuation, points, frontier_reach(), observed);
    const PairedEvidence e = paired_evidence(top_log_, top_observed_, log, observed, evidence_dead_band());
    evidence = params_.hypothesis_evidence_points * e.sum / static_cast<double>(points.size());
    // With the continuation at the frontier of unmapped space (weigh_hypotheses) the scan cannot prove the
    // challenger: the frontier fits worse than a mapped look-alike wherever the robot is. It can still disprove it.
    if (mapped_track_ && fit.coverage() < kMostOfTheScan) evidence = std::min(evidence, 0.0);
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

LookAlikeMemory::Verdict ParticleFilter::judge_places(const Pose& a, const Pose& b,
                                                      const std::vector<Eigen::Vector3f>& points) const {
  EndpointModel plain = params_.sensor;
  plain.weight_exponent = 1.0f;
  // The frontier's points are no evidence between places (drop_frontier_points), whatever the phase of the search.
  const float reach = params_.frontier_evidence ? 0.0f : map_.truncation();
  // The memory judges many places against one track on one scan: the track's side once.
  if (!(judged_.step == step_ && judged_.points == points.data() && judged_.pose.matrix() == a.matrix())) {
    judged_.evidence = point_evidence(map_, plain, a, points, params_.inlier_distance, reach);
    judged_.step = step_;
    judged_.points = points.data();
    judged_.pose = a;
  }
  const PointEvidence place = point_evidence(map_, plain, b, points, params_.inlier_distance, reach);
  const PairedEvidence e = paired_evidence(judged_.evidence, place, evidence_dead_band());
  LookAlikeMemory::Verdict v;
  v.evidence =
      params_.hypothesis_evidence_points * e.sum / static_cast<double>(std::max<std::size_t>(points.size(), 1));
  v.track_explained = judged_.evidence.fit.absolute_inlier_ratio();
  v.place_explained = place.fit.absolute_inlier_ratio();
  return v;
}

void ParticleFilter::remember_look_alikes(const Pose& delta, const std::vector<Eigen::Vector3f>& points,
                                          FilterStep& step) {
  const std::vector<Hypothesis>& h = estimate_.hypotheses;
  look_alike_to_restore_.reset();  // this update's or none (one that recovery or a restore kept waiting is stale)
  // A local start's pose is what tells its place from look-alikes: the operator's, not the scans'.
  if (!look_alikes_.enabled() || h.empty() || local_start_) return;
  // The other hypotheses that explain about as much of the scan as the track (LookAlikeOptions::explain_margin): the
  // others are no look-alikes, and judging them costs a ray march each.
  std::vector<Pose> others;
  for (std::size_t k = 1; k < h.size(); ++k) {
    if (explained_share(h[k]) >= explained_share(h.front()) - params_.look_alikes.explain_margin)
      others.push_back(h[k].pose);
  }
  // And the places this scan fits best whatever their share: a challenger the background search just placed holds
  // too little of the belief to be among the heaviest modes, and resampling may drop it before it is one. The best
  // particle of each of up to kFittestPlaces places outside the hypotheses (among the best 512 there).
  const ParticleArrays p = evaluator_.particles();
  std::vector<Pose> taken;
  for (const Hypothesis& x : h) taken.push_back(x.pose);
  const auto taken_near = [&](const Eigen::Vector3d& at) {
    return std::any_of(taken.begin(), taken.end(),
                       [&](const Pose& t) { return (t.translation() - at).norm() <= kTrackRadius; });
  };
  std::vector<std::uint32_t>& elsewhere = elsewhere_;  // reused: up to the whole particle set, every update
  elsewhere.clear();
  for (std::size_t i = 0; i < count_; ++i) {
    if (!taken_near(p.position(i).cast<double>())) elsewhere.push_back(static_cast<std::uint32_t>(i));
  }
  const auto better = [&](std::uint32_t a, std::uint32_t b) {
    return p.log_weight[a] > p.log_weight[b] || (p.log_weight[a] == p.log_weight[b] && a < b);
  };
  const std::size_t best = std::min<std::size_t>(elsewhere.size(), 512);
  std::partial_sort(elsewhere.begin(), elsewhere.begin() + static_cast<std::ptrdiff_t>(best), elsewhere.end(), better);
  std::vector<Pose> fittest;
  for (std::size_t k = 0; k < best && fittest.size() < kFittestPlaces; ++k) {
    Pose pose = Pose::Identity();
    pose.linear() = p.rotation(elsewhere[k]).cast<double>().normalized().toRotationMatrix();
    pose.translation() = p.position(elsewhere[k]).cast<double>();
    if (taken_near(pose.translation())) continue;
    taken.push_back(pose);
    fittest.push_back(pose);
  }
  std::vector<WallTilt> walls;
  for (const Pose& pose : fittest) walls.push_back(walls_at(pose));
#pragma omp parallel for schedule(dynamic)
  for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(fittest.size()); ++k) {
    const auto i = static_cast<std::size_t>(k);
    fittest[i] = refine_pose(map_, fittest[i], points, 6, &walls[i]);
  }
  others.insert(others.end(), fittest.begin(), fittest.end());
  look_alikes_.update(h.front().pose, delta, others, points, !(h.front().coverage < kMostOfTheScan));
  step.look_alikes = look_alikes_.places();
  // A look-alike proven better that the belief holds less than half the share of: the next resampling gives it the
  // share its evidence does, less what the belief holds there (the hypotheses near it). Not before the belief first
  // concentrated: a global search's spread belief holds its places itself, and the memory's "track" is only its
  // heaviest mode (particles put at the best of 8 look-alikes 12 scans into the search delayed the two-storey VLP-16
  // ground-3 run's first right estimate by 20 scans).
  // Until the track first converges it was never proven against its look-alikes either: then any kept look-alike
  // takes the share its evidence gives it, not only a proven one. In the two-storey OS0-64 drone-4 run the global
  // search put no particle on the true storey; the memory kept it level with the track (evidence near 0) for 210
  // scans while the belief held next to nothing there, and when the staircase came into view the refute_nats of a
  // proof took 4 scans; a belief holding both storeys turns on the first scans that tell them apart.
  // Only once the memory has judged it over proof_window_m of travel, the span over which a view tells look-alikes
  // apart: a place found this scan has no standing yet, and in the symmetric building's VLP-16 handheld-6 run places
  // found while the robot stood at the cabinet took 0.13 and 0.23 of a belief that had just turned to the right wing,
  // and its track sat 0.3 m off for 30 scans.
  if (!ever_concentrated_) return;
  const auto held_at = [&](const Pose& place) {
    double held = 0.0;
    for (const Hypothesis& x : h) {
      if ((x.pose.translation() - place.translation()).norm() <= params_.convergence.max_jump_m) held += x.weight;
    }
    return held;
  };
  std::vector<LookAlikeMemory::Standing> candidates;
  if (const auto& proven = look_alikes_.proven()) candidates.push_back(*proven);
  if (!ever_converged_ && !(h.front().coverage < kMostOfTheScan)) {
    for (const LookAlikeMemory::Standing& l : look_alikes_.kept()) {
      if (l.travelled >= params_.look_alikes.proof_window_m) candidates.push_back(l);
    }
  }
  // The one the belief lacks most, if it holds less than half of what its evidence gives.
  double lacked = 0.0;
  for (const LookAlikeMemory::Standing& l : candidates) {
    const double held = held_at(l.place);
    const double want = l.odds_share();
    if (held < 0.5 * want && want - held > lacked) {
      lacked = want - held;
      look_alike_to_restore_ = LookAlikeToRestore{l.place, (want - held) / (1.0 - held)};
    }
  }
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

}  // namespace tsdf_mcl
