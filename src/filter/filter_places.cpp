// The places of the belief (filter_core.hpp; docs/filter.md, "Places"): the modes, each refined onto the map, and the
// evidence between them, which moves their shares while the particles within one keep their relative weights.
#include <algorithm>
#include <cmath>
#include <limits>

#include "filter_core.hpp"
#include "place_refinement.hpp"
#include "tsdf_mcl/filter/place_weighting.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"

namespace tsdf_mcl {

struct ParticleFilter::Core::PlaceFits {
  RefinedPlaces refined;
  std::vector<bool> waits;       // the place's evidence against the reference waits at a frontier
  std::vector<double> evidence;  // per point against the best, one per place and then the rest's
};

namespace {

EndpointModel plain_model(const EndpointModel& sensor) {
  EndpointModel plain = sensor;
  plain.weight_exponent = 1.0f;
  return plain;
}

// What a verdict between the places rests on: each one's spread and its fit at its refined pose.
std::vector<PlaceJudgement> place_judgements(const std::vector<Place>& h, const std::vector<RayFit>& fit,
                                             const std::vector<bool>& waits, const PoseEstimateOptions& options) {
  std::vector<PlaceJudgement> judged(h.size());
  for (std::size_t r = 0; r < h.size(); ++r) {
    judged[r] = PlaceJudgement{compact(h[r], options), waits[r], fit[r].coverage(), fit[r].inlier_ratio()};
  }
  return judged;
}

}  // namespace

void ParticleFilter::Core::weigh_places(std::size_t n, const std::vector<Eigen::Vector3f>& points, FilterStep& step) {
  estimate_ = estimator_.estimate(evaluator_.particles(), weights_.data(), n);
  const auto rest = static_cast<std::int32_t>(estimate_.places.size());  // the particles in no place
  for (std::size_t i = 0; i < n; ++i) {
    const std::int32_t g = estimator_.place_of(i);
    group_[i] = g >= 0 ? g : rest;
  }
  PlaceFits fits = fit_places(n, points);
  std::vector<double> nats = place_nats(n, fits, points, step);
  even_places_as_named(n, fits, nats);
  turn_on_decisive_views(n, fits, fits.evidence, nats);
  group_share_ = reweight_groups(prior_log_weight_.data(), post_log_weight_.data(), group_.data(), n, nats);
  take_shares(n, fits, step);
}

ParticleFilter::Core::PlaceFits ParticleFilter::Core::fit_places(std::size_t n,
                                                                 const std::vector<Eigen::Vector3f>& points) {
  // Each place refined from its mean, and a spread one also from its heaviest particle (the mean of a spread mode sits
  // off its place: a robot turning on the spot spreads its yaw); once the places are named and until the belief first
  // concentrates, a compact place that fits clearly worse than the best one again from its refine_starts heaviest
  // particles (a mode's mean that sat 0.1 m high settled there, and single such updates turned a storey's share).
  // Not while the search's modes are still spread: there the luck of which mode held a well-placed particle decided.
  const PlaceOptions& o = params_.places;
  const std::vector<Place>& h = estimate_.places;
  const std::vector<std::vector<std::size_t>> heaviest =
      heaviest_particles(group_.data(), weights_.data(), n, h.size(), o.refine_starts);
  std::vector<std::vector<std::size_t>> starts(h.size());
  for (std::size_t r = 0; r < h.size(); ++r) {
    if (!heaviest[r].empty()) starts[r].push_back(heaviest[r].front());
  }
  const auto refine = [&] {
    return refine_places(map_, h, evaluator_.particles(), starts, points, plain_model(params_.sensor),
                         o.inlier_distance, frontier_reach(), evidence_dead_band(),
                         [this](const Pose& pose) { return walls_at(pose); });
  };
  PlaceFits fits;
  fits.refined = refine();
  if (phase_ == Phase::kPlacesNamed) {
    double best_inliers = 0.0;
    for (const RayFit& f : fits.refined.fit) best_inliers = std::max(best_inliers, f.inlier_ratio());
    bool again = false;
    for (std::size_t r = 0; r < h.size(); ++r) {
      if (h[r].weight < o.min_weight || !compact(h[r], params_.estimate) ||
          best_inliers - fits.refined.fit[r].inlier_ratio() < o.refine_again_gap)
        continue;
      starts[r] = heaviest[r];
      again = true;
    }
    if (again) fits.refined = refine();
  }
  // Where a place that fits its observed points well lies mostly in space the map never observed (after the belief
  // has followed a covered place), or where a door into such space comes into view between two look-alikes, the
  // pair's evidence waits (place_weighting.hpp: waiting_pairs).
  const RefinedPlaces& p = fits.refined;
  std::vector<FrontierView> views(h.size());
  for (std::size_t r = 0; r < h.size(); ++r) {
    const bool near = (p.pose[r].translation() - p.pose[p.reference].translation()).norm() <= o.track_radius;
    views[r] = FrontierView{p.fit[r].coverage(), at_frontier_of(p.fit[r], p.pose[r]), near};
  }
  fits.waits = waiting_pairs(views, p.reference, o.most_of_the_scan, o.frontier_coverage_gap);
  return fits;
}

std::vector<double> ParticleFilter::Core::place_nats(std::size_t n, PlaceFits& fits,
                                                     const std::vector<Eigen::Vector3f>& points,
                                                     const FilterStep& step) {
  // Between places only the points one place explains and the other does not are evidence: each point's
  // log-likelihood difference to the best-fitting place counts beyond a dead band, on the points observed at both
  // (scan_fit.hpp: paired_evidence). Two look-alike rooms differ in every point by the millimetres their refined poses
  // happen to differ by; summed, those were a random walk that decided between identical places.
  const RefinedPlaces& p = fits.refined;
  const std::size_t places = p.pose.size();
  const auto count = static_cast<double>(points.size());
  const double dead_band = evidence_dead_band();
  std::vector<double> paired(places, 0.0);
  for (std::size_t r = 0; r < places; ++r) {
    paired[r] =
        paired_evidence(p.point_log[r], p.observed[r], p.point_log[p.reference], p.observed[p.reference], dead_band)
            .sum;
  }
  std::vector<double>& evidence = fits.evidence;
  evidence = place_evidence(p.total[p.reference], paired, fits.waits, count);
  evidence.push_back(0.0);  // the rest's
  // The rest has no place to pair its points with: its marginal likelihood counts the points in unobserved space as
  // misses. While the dominant place is at the frontier of unmapped space that would hand its share to stray particles
  // at mapped places; like a pair's evidence there, theirs waits: no more than the best place's.
  const double rest_per_point = rest_evidence(n, places + 1, count);
  if (!std::isnan(rest_per_point)) {
    evidence[places] = places > 0 && at_frontier(p.fit[0], p.pose[0])
                           ? std::min(rest_per_point, p.total[p.reference] / count)
                           : rest_per_point;
  }
  const double best = *std::max_element(evidence.begin(), evidence.end());
  // A scan counts as evidence_points independent points between places; until the belief first concentrates no more
  // than the tempering lets the particles count it (a spread, global belief: no early verdict between its modes).
  const double per_point = step.tempering * params_.sensor.weight_exponent * count;
  const double full = params_.places.evidence_points;
  const double scale = full <= 0.0 ? per_point : concentrated_once() ? full : std::min(full, per_point);
  std::vector<double> nats(evidence.size());
  for (std::size_t k = 0; k < evidence.size(); ++k) nats[k] = scale * (evidence[k] - best);
  return nats;
}

void ParticleFilter::Core::even_places_as_named(std::size_t n, const PlaceFits& fits, std::vector<double>& nats) {
  // As a global search names its places, tied ones start equal (PlaceOptions::even_tied). A local start's place is
  // the operator's; once the belief has concentrated, its shares are evidence.
  const PlaceOptions& o = params_.places;
  if (!o.even_tied || phase_ != Phase::kSearching || local_start_ || o.evidence_points <= 0.0) return;
  even_tied_places(place_judgements(estimate_.places, fits.refined.fit, fits.waits, params_.estimate),
                   o.decisive_inlier_gap, o.nearly_all_of_the_scan,
                   group_log_sums(prior_log_weight_.data(), group_.data(), n, nats.size()), nats);
}

void ParticleFilter::Core::turn_on_decisive_views(std::size_t n, const PlaceFits& fits,
                                                  const std::vector<double>& evidence, std::vector<double>& nats) {
  // Before the belief first concentrates, a place beaten decisively on this update and the last (the same two places
  // carried by the odometry) has the odds turned against it (place_weighting.hpp: decisively_beaten, turn_odds): a
  // place whose refined pose landed off for one update loses a single verdict only.
  const PlaceOptions& o = params_.places;
  std::vector<std::pair<Pose, Pose>> decisive;
  if (!concentrated_once() && o.evidence_points > 0.0) {
    const std::vector<Pose>& poses = fits.refined.pose;
    std::size_t b = poses.size();
    const std::vector<std::size_t> beaten =
        decisively_beaten(place_judgements(estimate_.places, fits.refined.fit, fits.waits, params_.estimate), evidence,
                          o.decisive_inlier_gap, o.nearly_all_of_the_scan, b);
    const auto same = [&](const Pose& before, const Pose& now) {
      return params_.same_place(before * update_delta_, now);
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
                o.evidence_points, 2.0 * std::log(o.switch_ratio), nats);
    }
  }
  decisive_before_.swap(decisive);
}

void ParticleFilter::Core::take_shares(std::size_t n, const PlaceFits& fits, FilterStep& step) {
  const double max =
      *std::max_element(post_log_weight_.begin(), post_log_weight_.begin() + static_cast<std::ptrdiff_t>(n));
  for (std::size_t i = 0; i < n; ++i) weights_[i] = std::exp(post_log_weight_[i] - max);
  step.ess = effective_sample_size(weights_.data(), n);
  std::vector<Place>& h = estimate_.places;
  const RefinedPlaces& p = fits.refined;
  double compact_share = 0.0;
  for (std::size_t r = 0; r < h.size(); ++r) {
    h[r].weight = group_share_[r];
    h[r].pose = p.pose[r];
    h[r].inlier_ratio = p.fit[r].inlier_ratio();
    h[r].coverage = p.fit[r].coverage();
    h[r].see_through_ratio = p.fit[r].see_through_ratio();
    compact_share += compact(h[r], params_.estimate) ? h[r].weight : 0.0;
  }
  if (phase_ == Phase::kSearching && compact_share >= params_.estimate.converged_weight) phase_ = Phase::kPlacesNamed;
  rank_places(n, h, static_cast<std::int32_t>(h.size()));
  covered_streak_ = h.front().coverage >= params_.places.most_of_the_scan ? covered_streak_ + 1 : 0;
  mapped_track_ = mapped_track_ || covered_streak_ >= params_.places.mapped_track_updates;
  step.concentrated = take_dominant_place(estimate_, params_.estimate);
  dominant_concentrated_ = step.concentrated;
  if (step.concentrated && phase_ < Phase::kConcentrated) phase_ = Phase::kConcentrated;
  keep_estimate_place(step);
}

void ParticleFilter::Core::keep_estimate_place(const FilterStep& step) {
  if (step.concentrated || !estimate_prediction_ || params_.estimate.best_particle) return;
  const std::size_t k = estimate_place(estimate_.places, *estimate_prediction_, params_.places.switch_ratio,
                                       params_.same_place.max_m, params_.same_place.max_rad);
  if (k != 0) take_place(estimate_, k, params_.estimate);
}

bool ParticleFilter::Core::at_frontier(const RayFit& fit, const Pose& pose) const {
  return fit.coverage() < params_.places.most_of_the_scan && at_frontier_of(fit, pose);
}

bool ParticleFilter::Core::at_frontier_of(const RayFit& fit, const Pose& pose) const {
  if (!mapped_track_) return false;
  if (fit.inlier_ratio() >= params_.places.frontier_min_inliers) return true;
  return track_prediction_ && params_.same_place(pose, *track_prediction_);
}

double ParticleFilter::Core::rest_evidence(std::size_t n, std::size_t groups, double points) {
  const ParticleArrays p = evaluator_.particles();
  const double to_plain = 1.0 / params_.sensor.weight_exponent;
  for (std::size_t i = 0; i < n; ++i) weights_[i] = prior_log_weight_[i] + to_plain * p.log_weight[i];
  const std::vector<double> with = group_log_sums(weights_.data(), group_.data(), n, groups);
  const std::vector<double> without = group_log_sums(prior_log_weight_.data(), group_.data(), n, groups);
  const std::size_t rest = groups - 1;
  if (!std::isfinite(with[rest]) || !std::isfinite(without[rest])) return std::numeric_limits<double>::quiet_NaN();
  return (with[rest] - without[rest]) / points;
}

void ParticleFilter::Core::rank_places(std::size_t n, std::vector<Place>& h, std::int32_t rest_group) {
  std::vector<std::int32_t> rank(h.size());
  for (std::size_t r = 0; r < h.size(); ++r) rank[r] = static_cast<std::int32_t>(r);
  std::stable_sort(rank.begin(), rank.end(), [&](std::int32_t a, std::int32_t b) {
    return h[static_cast<std::size_t>(a)].weight > h[static_cast<std::size_t>(b)].weight;
  });
  std::vector<Place> sorted;
  std::vector<std::int32_t> new_index(h.size() + 1, rest_group);
  std::vector<double> shares(h.size() + 1, group_share_[h.size()]);
  for (std::size_t r = 0; r < rank.size(); ++r) {
    sorted.push_back(h[static_cast<std::size_t>(rank[r])]);
    new_index[static_cast<std::size_t>(rank[r])] = static_cast<std::int32_t>(r);
    shares[r] = group_share_[static_cast<std::size_t>(rank[r])];
  }
  for (std::size_t i = 0; i < n; ++i) group_[i] = new_index[static_cast<std::size_t>(group_[i])];
  group_share_ = shares;
  h = std::move(sorted);
}

double ParticleFilter::Core::evidence_dead_band() const {
  const float d = params_.places.inlier_distance;
  const float s = params_.sensor.sigma_hit;
  return 0.5 * static_cast<double>(d * d) / static_cast<double>(s * s);
}

float ParticleFilter::Core::frontier_reach() const {
  // Only once the belief has followed a place the map covers: a global search's first updates need every point to
  // tell places apart (the avz building is open to the sky, so every wall top is a frontier).
  return params_.places.frontier_evidence || !mapped_track_ ? 0.0f : map_.truncation();
}

}  // namespace tsdf_mcl
