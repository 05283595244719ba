// Unknown is unknown within each place (filter_core.hpp; docs/filter.md, "Which points are evidence"). Once there is a
// track to keep, each compact place's particles (those near its predicted pose) are weighed against each other on the
// points that land, at that pose, clear of space the map never observed and of its frontier, so none gains by pushing
// the scan out of the unobserved band (a drone whose map's walls end where the mapping robot's view did sank towards
// the floor). Each place's total against the others stays the whole scan's (and so do the tempering, recovery's fit and
// the places' evidence): the points a place never observed are evidence against a look-alike that did.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "filter_core.hpp"

namespace tsdf_mcl {

std::vector<Pose> ParticleFilter::Core::own_point_centres(const Pose& delta, double reach) const {
  // Once there is a track to keep: the last update's dominant place held the belief, concentrated, or the filter has
  // converged since its (re)start. A global search before that is weighed on the whole scan: it needs every point to
  // tell places apart, and weighing its places on their own points tipped which of a symmetric building's two wings
  // led.
  std::vector<Pose> centres;
  if (!dominant_concentrated_ && !converged_once()) {
    // A local start names its place: the track to keep is there from the first update, spread as the start was.
    if (local_start_) centres.push_back(last_estimate_pose_ * delta);
    return centres;
  }
  // The belief as a few compact places: each that passes the convergence test's spread (and is spread less than
  // `reach`), and the estimate's own (the held track may hold a sliver of the belief). A place spread wider takes the
  // whole scan, which draws it together again.
  const PoseEstimateOptions& o = params_.estimate;
  const double spread = std::min(reach, o.converged_std_xyz);
  const auto within_spread = [&](double std_position, double std_rotation) {
    return std_position <= spread && std_rotation <= o.converged_std_angle;
  };
  const auto add = [&](const Pose& pose) {
    for (const Pose& c : centres) {
      if ((c.translation() - pose.translation()).norm() <= params_.places.track_radius) return;
    }
    centres.push_back(pose);
  };
  double compact_weight = 0.0;
  if (within_spread(estimate_.std_position, estimate_.std_rotation)) add(last_estimate_pose_ * delta);
  for (const Place& h : estimate_.places) {
    if (centres.size() >= params_.places.max_own_places) break;
    if (!within_spread(h.std_position, h.std_rotation)) continue;
    compact_weight += h.weight;
    add(h.pose * delta);
  }
  // A belief spread wider than those places is weighed on the whole scan (and too large to weigh twice).
  if (compact_weight < o.converged_weight) centres.clear();
  return centres;
}

void ParticleFilter::Core::weigh_own_points(std::size_t n, const std::vector<Eigen::Vector3f>& points,
                                            const Pose& delta, FilterStep& step) {
  own_places_ = 0;
  if (params_.places.frontier_evidence) return;
  // Places spread less than a truncation length: a point a truncation length clear of unobserved space at a place's
  // predicted pose stays clear of it under each of its particles that matter.
  const std::vector<Pose> centres = own_point_centres(delta, static_cast<double>(map_.truncation()));
  if (centres.empty()) return;
  own_place_of_.assign(n, -1);
  for (std::size_t c = 0; c < centres.size(); ++c) {
    if (weigh_place_on_own_points(n, c, centres[c], points, step)) own_places_ = c + 1;
  }
}

bool ParticleFilter::Core::weigh_place_on_own_points(std::size_t n, std::size_t c, const Pose& centre,
                                                     const std::vector<Eigen::Vector3f>& points, FilterStep& step) {
  const float reach = map_.truncation();
  const RayFit centre_fit =
      ray_fit(map_, centre, points, params_.places.inlier_distance, kSeeThroughMargin, &own_observed_);
  const double below_coverage =
      params_.places.see_through_weight > 0.0 ? coverage_below_horizon(centre, points, own_observed_) : 0.0;
  const std::size_t dropped = drop_frontier_points(map_, centre, points, reach, own_observed_);
  std::size_t unobserved = 0;
  for (const std::uint8_t o : own_observed_) unobserved += o ? 0 : 1;
  // Nothing to drop (the place's whole scan is evidence), or too little left to weigh on (deep in a room the mapping
  // run never entered): the whole scan.
  if (dropped == 0 && unobserved == 0) return false;
  if (points.size() - unobserved < std::max<std::size_t>(params_.places.min_own_points, points.size() / 8))
    return false;
  own_points_.clear();
  for (std::size_t j = 0; j < points.size(); ++j) {
    if (own_observed_[j]) own_points_.push_back(points[j]);
  }
  // The place's particles (not already another's), gathered into the spare set and weighed on its points.
  const ParticleArrays p = evaluator_.particles();
  members_.clear();
  const Eigen::Vector3f at = centre.translation().cast<float>();
  const auto near = static_cast<float>(params_.places.track_radius);
  for (std::size_t i = 0; i < n; ++i) {
    if (own_place_of_[i] < 0 && (Eigen::Vector3f(p.x[i], p.y[i], p.z[i]) - at).norm() <= near) {
      members_.push_back(static_cast<std::uint32_t>(i));
    }
  }
  if (members_.empty()) return false;
  const ParticleArrays spare = evaluator_.spare_particles();
  for (std::size_t j = 0; j < members_.size(); ++j) spare.set(j, p.position(members_[j]), p.rotation(members_[j]));
  evaluator_.swap_particles();
  try {
    evaluator_.set_points(own_points_);
    evaluator_.weigh(members_.size(), params_.sensor);
  } catch (...) {
    evaluator_.swap_particles();
    throw;
  }
  evaluator_.swap_particles();
  own_log_weight_.resize(n);
  for (std::size_t j = 0; j < members_.size(); ++j) {
    own_place_of_[members_[j]] = static_cast<std::int32_t>(c);
    own_log_weight_[members_[j]] = spare.log_weight[j];
  }
  weigh_height_on_rays(centre, points, centre_fit, below_coverage);
  // The report's figure: the first place weighed so, the estimate's where it was.
  if (step.weighed_points == 0) step.weighed_points = own_points_.size();
  return true;
}

double ParticleFilter::Core::coverage_below_horizon(const Pose& centre, const std::vector<Eigen::Vector3f>& points,
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

void ParticleFilter::Core::weigh_height_on_rays(const Pose& centre, const std::vector<Eigen::Vector3f>& points,
                                                const RayFit& centre_fit, double below_coverage) {
  // Only where the map holds most of what the sensor sees below its horizon (the floor and what stands on it), whose
  // surfaces the lowered rays pass through: deep in a room the mapping run skipped the rays meet the map's residue.
  // And only at a place that fits as a track that may converge (converged_min_inliers): at a wrong place the rays see
  // through at every height, and weighed they hid a kidnapping from the search.
  const PlaceOptions& o = params_.places;
  if (!(o.see_through_weight > 0.0) || below_coverage < o.most_of_the_scan) return;
  if (centre_fit.inlier_ratio() < params_.states.min_inliers) return;
  // The rays' see-through at the place's pose shifted along the map's up axis by up to a truncation length in thirds:
  // off in height, rays that end on a mapped surface at the true pose pass into it before they end. Each particle
  // takes the count at its own height (linear between the steps, the ends held).
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
        static_cast<double>(ray_fit(map_, shifted, points, o.inlier_distance, kSeeThroughMargin).see_through);
  }
  // A ray through a surface costs what a point far from every surface costs against one on it, tempered like the
  // points (the sensor model's exponent; the update's tempering applies to both in weigh_within_places).
  const EndpointModel& m = params_.sensor;
  const double per_ray = o.see_through_weight * static_cast<double>(m.weight_exponent) *
                         std::log((m.hit_scale() + m.p_rand()) / m.p_rand());
  const ParticleArrays p = evaluator_.particles();
  for (const std::uint32_t i : members_) {
    const double offset = (Eigen::Vector3d(p.x[i], p.y[i], p.z[i]) - centre.translation()).dot(up) / step;
    const double u = std::clamp(offset, -static_cast<double>(kSteps), static_cast<double>(kSteps)) + kSteps;
    const auto k = static_cast<std::size_t>(std::min(std::floor(u), 2.0 * kSteps - 1.0));
    const double f = u - static_cast<double>(k);
    own_log_weight_[i] -= per_ray * ((1.0 - f) * see[k] + f * see[k + 1]);
  }
}

void ParticleFilter::Core::weigh_within_places(std::size_t n, double beta) {
  // Each place's posterior log-weights with its own points' likelihood, shifted so that their log-sum-exp (the place's
  // weight against every other) stays what the whole scan gave.
  for (std::size_t c = 0; c < own_places_; ++c) {
    double max_scan = -std::numeric_limits<double>::infinity();
    double max_own = -std::numeric_limits<double>::infinity();
    const auto place = static_cast<std::int32_t>(c);
    for (std::size_t i = 0; i < n; ++i) {
      if (own_place_of_[i] != place) continue;
      own_log_weight_[i] = prior_log_weight_[i] + beta * own_log_weight_[i];
      max_scan = std::max(max_scan, post_log_weight_[i]);
      max_own = std::max(max_own, own_log_weight_[i]);
    }
    if (!std::isfinite(max_scan)) continue;  // the whole scan weighed this place
    double sum_scan = 0.0;
    double sum_own = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      if (own_place_of_[i] != place) continue;
      sum_scan += std::exp(post_log_weight_[i] - max_scan);
      sum_own += std::exp(own_log_weight_[i] - max_own);
    }
    const double shift = (max_scan + std::log(sum_scan)) - (max_own + std::log(sum_own));
    for (std::size_t i = 0; i < n; ++i) {
      if (own_place_of_[i] == place) post_log_weight_[i] = own_log_weight_[i] + shift;
    }
  }
  const double max =
      *std::max_element(post_log_weight_.begin(), post_log_weight_.begin() + static_cast<std::ptrdiff_t>(n));
  for (std::size_t i = 0; i < n; ++i) weights_[i] = std::exp(post_log_weight_[i] - max);
}

}  // namespace tsdf_mcl
