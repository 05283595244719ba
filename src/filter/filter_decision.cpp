// ParticleFilter's decision (filter_core.hpp; docs/filter.md, "The ledger", "States"): how well the belief fits
// (recovery, a wrong lock), the ledger's turn on the track and its rivals, what the next resampling restores, and the
// state.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "filter_core.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"

namespace tsdf_mcl {

void ParticleFilter::Core::judge_belief(std::size_t n, const std::vector<Eigen::Vector3f>& points,
                                        const WeightSummary& summary, FilterStep& step) {
  step.fit = belief_fit(n, summary, points.size());
  // Recovery follows the dominant place's inlier ratio: it falls when the track is lost and hardly moves on a correct
  // one. The averages start at the first convergence (a belief spread over the map fits badly by nature), and wait
  // while the map covers too little of a converged track's scan to judge it.
  if (converged_once() && (!trusted_track() || map_judges_track()))
    step.random_share = recovery_.update(judged_ratio());
  step.w_slow = recovery_.w_slow();
  step.w_fast = recovery_.w_fast();
  implausible_share_ = judge_fit(step);
  step.random_share = std::max(step.random_share, implausible_share_);
}

double ParticleFilter::Core::judge_fit(FilterStep& step) {
  // Absolute: once the belief has concentrated, a dominant place that explains too little of the scan is wrong,
  // however steady (a running average that started at a wrong lock would call it normal). A converged track is judged
  // on its observed points where the map covers most of its scan, and not at all where it covers too little (an
  // unmapped room); any other belief on the whole scan, and one whose scan the map hardly covers is off the map: a lost
  // belief drifts there, where nothing speaks against it.
  const double min_inliers = params_.recovery.min_inliers;
  const bool covered = !(estimate_.coverage < params_.states.min_coverage);
  const double ratio = judged_ratio();
  const bool judged = !trusted_track() || map_judges_track();
  const bool off_map = !trusted_track() && !covered;
  const bool implausible = min_inliers > 0.0 && concentrated_once() && judged && (ratio < min_inliers || off_map);
  implausible_streak_ = implausible ? implausible_streak_ + 1 : 0;
  step.implausible = implausible;
  if (implausible_streak_ < 2) return 0.0;
  const double share = std::clamp(1.0 - ratio / min_inliers, 0.0, 1.0);
  return off_map ? std::max(share, 1.0 - estimate_.coverage / params_.states.min_coverage) : share;
}

bool ParticleFilter::Core::map_judges_track() const {
  return !(estimate_.coverage < std::max(params_.states.min_coverage, params_.places.most_of_the_scan));
}

double ParticleFilter::Core::judged_ratio() const {
  if (trusted_track()) return estimate_.inlier_ratio;
  return explained_share(estimate_.inlier_ratio, estimate_.coverage);
}

void ParticleFilter::Core::follow_track(const Pose& delta, double dt, const std::vector<Eigen::Vector3f>& points,
                                        FilterStep& step) {
  restore_.reset();
  if (estimate_.places.empty()) return;
  const Place& top = estimate_.places.front();
  PlaceLedger::Input in;
  in.motion = delta;
  in.track = top.pose;
  // After the first convergence the track holds against a dominant place elsewhere: its own continuation, refined.
  std::optional<Pose> continuation;
  RayFit fit;
  if (converged_once() && ledger_.started()) {
    const Pose predicted = ledger_.predict(delta);
    if (!params_.same_place(predicted, top.pose)) {
      const WallTilt walls = walls_at(predicted);
      const Pose c = refine_pose(map_, predicted, points, 6, &walls);
      if (!params_.same_place(c, top.pose)) {
        continuation = c;
        fit = ray_fit(map_, c, points, params_.places.inlier_distance);
        in.track = c;
        in.challenger = top.pose;
        in.track_implausible = params_.recovery.min_inliers > 0.0 && !(fit.coverage() < params_.states.min_coverage) &&
                               fit.inlier_ratio() < params_.recovery.min_inliers;
      }
    }
  }
  in.track_mapped = !((continuation ? fit.coverage() : top.coverage) < params_.places.most_of_the_scan);
  // A local start's pose is what tells its place from look-alikes: the operator's, not the scans'.
  if (ledger_.enabled() && !local_start_) in.others = rivals_to_judge(points);
  const PlaceLedger::Outcome out = ledger_.update(in);
  step.holding = out.holding;
  step.challenge_evidence = out.challenge;
  step.challenge_travel = out.challenge_travel;
  for (const PlaceLedger::Standing& s : out.rivals) step.rivals.push_back(s.place);
  rivals_undecided_ = !out.rivals.empty();
  rival_proven_ = out.proven.has_value();
  if (continuation && !out.challenger_taken) {
    hold_track(*continuation, fit, delta, dt);
  } else {
    track_covariance_ = top.covariance;
  }
  plan_restore(out);
}

std::vector<Pose> ParticleFilter::Core::rivals_to_judge(const std::vector<Eigen::Vector3f>& points) {
  // The other places that explain about as much of the scan as the dominant one (the others are no rivals, and judging
  // them costs a ray march each), and the places this scan fits best whatever their share: a challenger the background
  // search just placed holds too little of the belief to be among the heaviest modes.
  const std::vector<Place>& h = estimate_.places;
  std::vector<Pose> others;
  for (std::size_t k = 1; k < h.size(); ++k) {
    if (explained_share(h[k]) >= explained_share(h.front()) - params_.ledger.explain_margin)
      others.push_back(h[k].pose);
  }
  // The search elsewhere finds new places; once found, the ledger follows them itself. So after the belief first
  // concentrated it runs when fresh particles have joined (challengers, recovery) and been weighed: on the update
  // after they came, not on every update (a refinement and a ray march per place).
  if (!concentrated_once() || fresh_particles_weighed_) {
    const std::vector<Pose> fittest = fittest_elsewhere(points);
    others.insert(others.end(), fittest.begin(), fittest.end());
  }
  return others;
}

std::vector<Pose> ParticleFilter::Core::fittest_elsewhere(const std::vector<Eigen::Vector3f>& points) {
  // The best particle of each of up to fittest_places places outside the belief's places (among the best 512 there),
  // refined onto the map.
  const ParticleArrays p = evaluator_.particles();
  const double radius = params_.places.track_radius;
  std::vector<Pose> taken;
  for (const Place& x : estimate_.places) taken.push_back(x.pose);
  const auto taken_near = [&](const Eigen::Vector3d& at) {
    return std::any_of(taken.begin(), taken.end(),
                       [&](const Pose& t) { return (t.translation() - at).norm() <= radius; });
  };
  elsewhere_.clear();
  for (std::size_t i = 0; i < count_; ++i) {
    if (!taken_near(p.position(i).cast<double>())) elsewhere_.push_back(static_cast<std::uint32_t>(i));
  }
  const auto better = [&](std::uint32_t a, std::uint32_t b) {
    return p.log_weight[a] > p.log_weight[b] || (p.log_weight[a] == p.log_weight[b] && a < b);
  };
  const std::size_t best = std::min<std::size_t>(elsewhere_.size(), 512);
  std::partial_sort(elsewhere_.begin(), elsewhere_.begin() + static_cast<std::ptrdiff_t>(best), elsewhere_.end(),
                    better);
  std::vector<Pose> fittest;
  for (std::size_t k = 0; k < best && fittest.size() < params_.places.fittest_places; ++k) {
    Pose pose = Pose::Identity();
    pose.linear() = p.rotation(elsewhere_[k]).cast<double>().normalized().toRotationMatrix();
    pose.translation() = p.position(elsewhere_[k]).cast<double>();
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
  return fittest;
}

void ParticleFilter::Core::hold_track(const Pose& continuation, const RayFit& fit, const Pose& delta, double dt) {
  // The estimate follows the track, carried by the odometry and refined on the scan, its covariance growing by the
  // motion noise of each update.
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
}

void ParticleFilter::Core::plan_restore(const PlaceLedger::Outcome& out) {
  // Where the ledger has decided for a place the belief holds less than half the share the ratio gives it (the track
  // against a refuted challenger, a rival proven better), the next resampling puts particles there with that share,
  // less what the belief holds: a set that had kept particles there would hold it. Until the track first converges it
  // was never proven against its rivals either: then any rival the ledger has followed over window_m of travel takes
  // its share so. Not before the belief first concentrates: a global search's spread belief holds its places itself.
  if (!concentrated_once()) return;
  const std::vector<Place>& h = estimate_.places;
  const auto held_at = [&](const Pose& place) {
    double held = 0.0;
    for (const Place& x : h) {
      if ((x.pose.translation() - place.translation()).norm() <= params_.same_place.max_m) held += x.weight;
    }
    return held;
  };
  std::vector<std::pair<Pose, double>> wanted;  // place, the share the ledger gives it
  if (out.challenger_refuted) wanted.emplace_back(out.track, 1.0 / (1.0 + std::exp(-params_.ledger.decide_nats)));
  const bool covered = !(h.front().coverage < params_.places.most_of_the_scan);
  for (const PlaceLedger::Standing& s : out.rivals) {
    if (s.proven || (!converged_once() && covered && s.travelled >= params_.ledger.window_m))
      wanted.emplace_back(s.place, s.odds_share());
  }
  double lacked = 0.0;
  for (const auto& [place, want] : wanted) {
    const double held = held_at(place);
    if (held < 0.5 * want && want - held > lacked) {
      lacked = want - held;
      restore_ = Restore{place, (want - held) / (1.0 - held)};
    }
  }
}

PlaceLedger::Verdict ParticleFilter::Core::judge_places(const Pose& track, const Pose& place,
                                                        const std::vector<Eigen::Vector3f>& points) {
  EndpointModel plain = params_.sensor;
  plain.weight_exponent = 1.0f;
  // The frontier's points are no evidence between places (drop_frontier_points), whatever the phase of the search.
  const float reach = params_.places.frontier_evidence ? 0.0f : map_.truncation();
  // The ledger judges many places against one track on one scan: the track's side once (the first call runs alone).
  if (!(judged_.step == step_ && judged_.pose.matrix() == track.matrix())) {
    judged_.evidence = point_evidence(map_, plain, track, points, params_.places.inlier_distance, reach);
    judged_.step = step_;
    judged_.pose = track;
  }
  const PointEvidence other = point_evidence(map_, plain, place, points, params_.places.inlier_distance, reach);
  const PairedEvidence e = paired_evidence(judged_.evidence, other, evidence_dead_band());
  PlaceLedger::Verdict v;
  v.evidence = params_.places.evidence_points * e.sum / static_cast<double>(std::max<std::size_t>(points.size(), 1));
  v.track_explained = judged_.evidence.fit.absolute_inlier_ratio();
  v.place_explained = other.fit.absolute_inlier_ratio();
  return v;
}

void ParticleFilter::Core::decide_state(FilterStep& step) {
  challengers_weighed_ = challengers_weighed_ || last_challenge_time_ > -1e300;
  StateEvidence e;
  e.place = estimate_.pose;
  e.motion = update_delta_;
  e.concentrated = step.concentrated && !step.holding;
  e.inliers = estimate_.inlier_ratio;
  e.coverage = estimate_.coverage;
  e.second_weight = estimate_.places.size() >= 2 ? estimate_.places[1].weight : 0.0;
  e.searched = challengers_weighed_ || params_.recovery.challenger_candidates == 0;
  e.rival_undecided = rivals_undecided_;
  e.rival_proven = rival_proven_;
  e.holding = step.holding;
  e.implausible = step.implausible;
  e.recovery_lost = step.random_share > 1.0 - params_.estimate.converged_weight;
  states_.update(e);
  estimate_.converged = states_.converged();
  if (estimate_.converged) phase_ = Phase::kConverged;
  if (implausible_share_ > 0.0) restart_after_wrong_lock();
  step.state = states_.state();
  step.reason = states_.reason();
  step.estimate = estimate_;
}

void ParticleFilter::Core::restart_after_wrong_lock() {
  // A wrong lock: search again as after a global initialization (roughening, averages forgotten).
  ledger_.reset();
  restore_.reset();
  if (phase_ > Phase::kConcentrated) phase_ = Phase::kConcentrated;
  local_start_ = false;
  recovery_.reset();
  states_.restart_after_wrong_lock();
  challengers_weighed_ = false;
  last_challenge_time_ = -1e300;
  covered_streak_ = 0;
  mapped_track_ = false;
}

}  // namespace tsdf_mcl
