// ParticleFilter: the life cycle and one update as its stages (filter_core.hpp names the file of each).
#include "tsdf_mcl/filter/particle_filter.hpp"

#include <algorithm>
#include <cmath>

#include "filter_core.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/stopwatch.hpp"

namespace tsdf_mcl {
namespace {

// The constant-velocity model trusts the motion between two estimates only while both are this certain (m, standard
// deviation of the dominant place): looser than `converged`, so that a track still settling after a local
// initialization already has a velocity, but far below the spread of a global belief.
constexpr double kVelocityMaxStd = 0.5;

}  // namespace

ParticleFilter::Core::Core(const TsdfMap& map, SensorEvaluator& evaluator, const FilterParameters& params,
                           std::size_t points_hint)
    : map_(map),
      evaluator_(evaluator),
      params_(params),
      kld_(params.kld),
      subset_first_(params.subset_first),
      motion_(params.motion.type),
      recovery_(params.recovery.alpha_slow, params.recovery.alpha_fast, params.recovery.margin),
      estimator_(params.estimate),
      ledger_(
          params.ledger, params.same_place,
          [this](const Pose& track, const Pose& place) { return judge_places(track, place, *scan_); },
          [this](const Pose& start) {
            const WallTilt walls = walls_at(start);
            return refine_pose(map_, start, *scan_, 6, &walls);
          }),
      states_(params.states, params.same_place, params.places.most_of_the_scan) {
  params_.validate();
  if (map.empty()) throw Error("the map is empty");
  if (params_.unknown_as_free) params_.sensor.unknown_distance = map.truncation();
  // A global search needs more room in the evaluator (its scratch space) only while it runs: see reserve_search();
  // the host arrays follow the particle set, which never exceeds this.
  capacity_ = std::max(params_.initial_particles, params_.kld.max_particles);
  points_capacity_ = std::max<std::size_t>(points_hint, 1);
  evaluator_.reserve(capacity_, points_capacity_);
  prior_log_weight_.assign(capacity_, 0.0);
  post_log_weight_.assign(capacity_, 0.0);
  weights_.assign(capacity_, 0.0);
  group_.assign(capacity_, 0);
  ancestors_.assign(capacity_, 0u);
}

GlobalProposal& ParticleFilter::Core::proposal() {
  if (!proposal_)
    proposal_ = std::make_unique<GlobalProposal>(map_, params_.global_init, params_.global_search.proposal);
  return *proposal_;
}

std::size_t ParticleFilter::Core::free_space_voxels() { return proposal().free_space().candidate_voxels(); }

std::vector<double> ParticleFilter::Core::particle_weights() const {
  std::vector<double> w(prior_log_weight_.begin(), prior_log_weight_.begin() + static_cast<std::ptrdiff_t>(count_));
  if (w.empty()) return w;
  const double max = *std::max_element(w.begin(), w.end());
  double sum = 0.0;
  for (double& v : w) sum += (v = std::exp(v - max));
  for (double& v : w) v /= sum;
  return w;
}

void ParticleFilter::Core::start(std::size_t count) {
  count_ = count;
  std::fill_n(prior_log_weight_.begin(), count_, 0.0);
  initialized_ = true;
  motion_.reset();
  updates_since_resample_ = 0;
  injected_begin_ = injected_end_ = 0;
  recovery_.reset();
  implausible_streak_ = 0;
  last_challenge_time_ = -1e300;
  challengers_weighed_ = false;
  fresh_particles_weighed_ = false;
  phase_ = Phase::kSearching;
  local_start_ = false;
  covered_streak_ = 0;
  mapped_track_ = false;
  dominant_concentrated_ = false;
  decisive_before_.clear();
  ledger_.reset();
  states_.reset();
  restore_.reset();
  estimate_ = PoseEstimate{};
  estimate_placed_ = false;
}

void ParticleFilter::Core::initialize_local(const Pose& pose, const LocalInitSpread& spread) {
  spread.validate();
  sample_local(evaluator_.particles(), params_.initial_particles, pose, spread, params_.seed, step_);
  ++step_;
  start(params_.initial_particles);
  local_start_ = true;
  estimate_.pose = pose;
  last_estimate_pose_ = pose;
  estimate_placed_ = true;
}

FilterStep ParticleFilter::Core::update(double time, const std::vector<Eigen::Vector3f>& points,
                                        const std::optional<Pose>& odometry, const ScanExtras& extras) {
  const Stopwatch started;
  if (!initialized_) throw Error("the particle filter is not initialized");
  if (points.empty()) throw Error("empty scan: no points left for the sensor update");
  if (params_.motion.type == MotionModelType::kOdometry && !odometry) {
    throw Error("motion_model odometry needs an odometry pose for every scan (odom.txt)");
  }
  Stopwatch t;
  const Pose delta = motion_.delta(time, odometry);
  if (!calls_for_update(delta, time)) return held_scan(delta, started.ms());
  const TrackState before = states_.state();
  FilterStep step;
  step.updated = true;
  step.points = points.size();
  step.particles = step.next_particles = count_;
  const std::size_t n = count_;
  const double dt = motion_.elapsed(time);
  scan_ = &points;
  update_delta_ = delta;
  track_prediction_ =
      converged_once() && ledger_.started() ? std::optional<Pose>(ledger_.predict(delta)) : std::nullopt;
  estimate_prediction_ = estimate_placed_ ? std::optional<Pose>(last_estimate_pose_ * delta) : std::nullopt;
  predict(n, delta, dt);
  step.timings.motion_ms = t.ms();

  const WeightSummary summary = weigh_scan(n, points, step);
  t = Stopwatch();
  read_walls(points, extras);
  step.timings.walls_ms = t.ms();
  t = Stopwatch();
  weigh_own_points(n, points, delta, step);
  step.timings.own_points_ms = t.ms();
  t = Stopwatch();
  temper(n, step);
  step.timings.tempering_ms = t.ms();
  t = Stopwatch();
  const bool was_localized = estimate_.std_position <= kVelocityMaxStd;
  weigh_places(n, points, step);
  step.timings.places_ms = t.ms();
  t = Stopwatch();
  judge_belief(n, points, summary, step);
  step.timings.decision_ms = t.ms();
  t = Stopwatch();
  follow_track(delta, dt, points, step);
  step.timings.ledger_ms = t.ms();
  t = Stopwatch();
  decide_state(step);
  step.timings.decision_ms += t.ms();
  // Only a localized track has a velocity; the jumps of a spread belief's estimate are not motion.
  motion_.observe_estimate(time, last_estimate_pose_, estimate_.pose,
                           was_localized && estimate_.std_position <= kVelocityMaxStd);

  t = Stopwatch();
  resample_policy(time, n, points, extras, step);
  step.timings.resample_ms = t.ms();
  step.next_particles = count_;
  motion_.finish_update(time, odometry);
  last_estimate_pose_ = estimate_.pose;
  estimate_placed_ = true;
  ++step_;
  step.state_changed = step.state != before;
  step.timings.total_ms = started.ms();
  return step;
}

FilterStep ParticleFilter::Core::held_scan(const Pose& delta, double started_ms) {
  FilterStep step;
  step.points = 0;
  step.particles = step.next_particles = count_;
  estimate_.pose = last_estimate_pose_ * delta;
  step.estimate = estimate_;
  step.state = states_.state();
  step.reason = states_.reason();
  step.timings.motion_ms = started_ms;
  step.timings.total_ms = started_ms;
  return step;
}

// The public face: everything forwards to the core.
ParticleFilter::ParticleFilter(const TsdfMap& map, SensorEvaluator& evaluator, const FilterParameters& params,
                               std::size_t points_hint)
    : core_(std::make_unique<Core>(map, evaluator, params, points_hint)) {}
ParticleFilter::~ParticleFilter() = default;
void ParticleFilter::initialize_global() { core_->initialize_global(); }
void ParticleFilter::initialize_global(const std::vector<Eigen::Vector3f>& points, const ScanExtras& extras) {
  core_->initialize_global(points, extras);
}
void ParticleFilter::initialize_local(const Pose& pose) { core_->initialize_local(pose, core_->params().local_init); }
void ParticleFilter::initialize_local(const Pose& pose, const LocalInitSpread& spread) {
  core_->initialize_local(pose, spread);
}
FilterStep ParticleFilter::update(double time, const std::vector<Eigen::Vector3f>& points,
                                  const std::optional<Pose>& odometry, const ScanExtras& extras) {
  return core_->update(time, points, odometry, extras);
}
void ParticleFilter::request_update() { core_->request_update(); }
bool ParticleFilter::initialized() const { return core_->initialized(); }
std::size_t ParticleFilter::particle_count() const { return core_->particle_count(); }
const PoseEstimate& ParticleFilter::estimate() const { return core_->estimate(); }
TrackState ParticleFilter::state() const { return core_->state(); }
const FilterParameters& ParticleFilter::params() const { return core_->params(); }
ParticleArrays ParticleFilter::particles() const { return core_->particles(); }
std::vector<double> ParticleFilter::particle_weights() const { return core_->particle_weights(); }
std::size_t ParticleFilter::free_space_voxels() { return core_->free_space_voxels(); }
const std::vector<GravityCandidate>& ParticleFilter::gravity_candidates() { return core_->gravity_candidates(); }

}  // namespace tsdf_mcl
