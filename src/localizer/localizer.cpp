#include "tsdf_mcl/localizer/localizer.hpp"

#include <algorithm>
#include <cstdio>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/backends/make_evaluator.hpp"
#include "tsdf_mcl/core/stopwatch.hpp"
#include "tsdf_mcl/localizer/map_extent_checks.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kImuKeep = 2.0;             // s of IMU samples kept before the latest one
constexpr std::size_t kUpdateTimes = 10000;  // updates the summary's median is taken over (the latest)

}  // namespace

Localizer::Localizer(const TsdfMap& map, const LocalizerOptions& options)
    : map_(map), options_(options), preprocessor_(options.preprocessing) {
  options_.filter.validate();
  check_options_for_map(map_, options_);
  evaluator_ = make_evaluator(map_, options_.evaluator, &backend_note_);
  filter_ = std::make_unique<ParticleFilter>(map_, *evaluator_, options_.filter, options_.preprocessing.max_beams);
  min_particles_ = max_particles_ = options_.filter.initial_particles;
  if (options_.initial_pose) reset_to(*options_.initial_pose);
}

Localizer::~Localizer() = default;

void Localizer::add_imu(const ImuSample& sample) {
  if (!imu_.empty() && sample.time < imu_.back().time) {
    throw Error("IMU samples must come in time order (" + std::to_string(sample.time) + " s after " +
                std::to_string(imu_.back().time) + " s)");
  }
  imu_.push_back(sample);
  while (!imu_.empty() && imu_.front().time < sample.time - kImuKeep) imu_.pop_front();
}

void Localizer::reset_to(const Pose& pose) { reset_to(pose, options_.filter.local_init); }

void Localizer::reset_to(const Pose& pose, const LocalInitSpread& spread) {
  check_pose_in_map(map_, pose, "the initial pose");
  check_spread_for_map(map_, spread, "the initial pose's ");
  const Stopwatch t0;
  filter_->initialize_local(pose, spread);
  pending_global_ = false;
  last_odometry_.reset();
  InitializationRecord r;
  r.global = false;
  r.particles = options_.filter.initial_particles;
  r.ms = t0.ms();
  initialization_ = r;
  converged_since_time_.reset();
  converged_since_index_.reset();
}

void Localizer::reset_global() {
  pending_global_ = true;
  last_odometry_.reset();
}

void Localizer::initialize(const std::vector<Eigen::Vector3f>* points, const ScanExtras& extras) {
  const Stopwatch t0;
  filter_->initialize_global(*points, extras);
  pending_global_ = false;
  InitializationRecord r;
  r.global = true;
  r.particles = options_.filter.initial_particles;
  r.hypotheses_scored = std::max(options_.filter.initial_particles, options_.filter.global_search.candidates);
  r.gravity_source = extras.imu_up ? "imu" : "scan";
  r.candidates = filter_->gravity_candidates();
  r.free_space_voxels = filter_->free_space_voxels();
  r.ms = t0.ms();
  initialization_ = r;
  converged_since_time_.reset();
  converged_since_index_.reset();
}

const ScanRecord& Localizer::process(double time, const std::vector<Eigen::Vector3f>& points,
                                     const std::optional<Pose>& odometry, std::optional<std::uint64_t> scan_id) {
  // Checked before anything changes: a refused scan leaves the localizer as it was.
  check_time(time, "the scan's stamp");
  // After an initialization the filter takes no motion from odometry (its reference starts anew), so neither does
  // the check: an operator's new pose or a global search recovers from odometry that jumped.
  if (odometry) check_odometry(map_, *odometry, last_odometry_, "the scan's odometry");
  record_ = ScanRecord{};
  record_.time = time;
  record_.index = scans_;
  const Stopwatch t0;
  const std::vector<Eigen::Vector3f>& selected =
      preprocessor_.process(points, scan_id.value_or(scans_), &record_.points);
  record_.preprocess_ms = t0.ms();
  if (selected.empty()) {
    char buf[160];
    std::snprintf(buf, sizeof(buf), "none of %zu points lies within laser_min_range %.2f m .. laser_max_range %.2f m",
                  points.size(), static_cast<double>(options_.preprocessing.laser_min_range),
                  static_cast<double>(options_.preprocessing.laser_max_range));
    throw Error(buf);
  }
  ScanExtras extras;
  extras.dense = &points;
  if (options_.use_imu && !imu_.empty()) {
    extras.imu_up = imu_up_at(std::vector<ImuSample>(imu_.begin(), imu_.end()), time);
  }
  if (pending_global_) initialize(&selected, extras);
  record_.particles_before = filter_->particle_count();
  record_.step = filter_->update(time, selected, odometry, extras);
  if (odometry) last_odometry_ = odometry;

  ++scans_;
  const FilterStep& step = record_.step;
  ++state_scans_[static_cast<std::size_t>(step.state)];
  if (step.updated) {
    if (step.estimate.coverage < coverage_min_) coverage_min_ = step.estimate.coverage;
    ++updates_;
    if (update_ms_.size() == kUpdateTimes) update_ms_.erase(update_ms_.begin());
    update_ms_.push_back(step.timings.total_ms);
    update_ms_sum_ += step.timings.total_ms;
    update_ms_max_ = std::max(update_ms_max_, step.timings.total_ms);
    min_particles_ = std::min(min_particles_, step.next_particles);
    max_particles_ = std::max(max_particles_, step.next_particles);
    if (!step.estimate.converged) {
      converged_since_time_.reset();
      converged_since_index_.reset();
    } else if (!converged_since_time_) {
      converged_since_time_ = time;
      converged_since_index_ = record_.index;
    }
  }
  return record_;
}

RunSummary Localizer::summary() const {
  RunSummary s;
  s.scans = scans_;
  s.updates = updates_;
  s.converged = filter_->estimate().converged;
  s.state = filter_->state();
  s.state_scans = state_scans_;
  s.coverage_min = coverage_min_;
  s.converged_since_time = converged_since_time_;
  s.converged_since_index = converged_since_index_;
  s.particles_min = min_particles_;
  s.particles_max = max_particles_;
  s.particles_final = filter_->particle_count();
  if (!update_ms_.empty()) {
    std::vector<double> sorted = update_ms_;
    std::sort(sorted.begin(), sorted.end());
    s.update_ms_mean = update_ms_sum_ / static_cast<double>(updates_);
    s.update_ms_median = sorted[sorted.size() / 2];
    s.update_ms_max = update_ms_max_;
  }
  return s;
}

ParticleSnapshot Localizer::snapshot() const {
  const ParticleArrays p = filter_->particles();
  const std::vector<double> w = filter_->particle_weights();
  ParticleSnapshot snapshot;
  snapshot.particles.resize(w.size());
  for (std::size_t i = 0; i < w.size(); ++i) {
    snapshot.particles[i].position = p.position(i);
    snapshot.particles[i].orientation = p.rotation(i);
    snapshot.particles[i].weight = static_cast<float>(w[i]);
  }
  for (const Place& h : filter_->estimate().places) {
    ParticleSnapshot::Particle m;
    m.position = h.pose.translation().cast<float>();
    m.orientation = Eigen::Quaternionf(Eigen::Quaterniond(h.pose.linear()).cast<float>());
    m.weight = static_cast<float>(h.weight);
    snapshot.hypotheses.push_back(m);
  }
  return snapshot;
}

}  // namespace tsdf_mcl
