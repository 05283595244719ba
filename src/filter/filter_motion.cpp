// ParticleFilter's MCL core on each update: the motion gate, the motion model, the sensor update and its tempering
// (filter_core.hpp).
#include <algorithm>
#include <cmath>
#include <string>

#include "filter_core.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"
#include "tsdf_mcl/filter/scan_gravity.hpp"
#include "tsdf_mcl/filter/tempering.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"

namespace tsdf_mcl {

bool ParticleFilter::Core::calls_for_update(const Pose& delta, double time) {
  bool moved = true;
  // The gate needs measured motion: with a predicted one it could hold a filter still forever. Before the first
  // convergence a standing robot still gets an update every roughening interval.
  if (motion_.has_update() && params_.motion.type == MotionModelType::kOdometry) {
    moved = delta.translation().norm() >= params_.update_min_d ||
            Eigen::AngleAxisd(delta.linear()).angle() >= params_.update_min_a ||
            (!converged_once() && motion_.elapsed(time) >= params_.roughening.interval);
  }
  moved = moved || force_update_;
  force_update_ = false;
  return moved;
}

void ParticleFilter::Core::predict(std::size_t n, const Pose& delta, double dt) {
  if (!motion_.has_update()) return;
  MotionNoise noise = motion_noise(params_.motion, delta, dt);
  // Roughening serves a sparse belief; once its dominant place holds the belief, concentrated, the motion noise keeps
  // that cloud alive, and a random walk per update lets a likelihood that favours one side (a drone whose map lacks the
  // band above the mapping robot's view: every particle below fits it better) carry the cloud off.
  if (!converged_once() && !dominant_concentrated_) {
    const auto rt = static_cast<float>(params_.roughening.xyz);
    const auto ra = static_cast<float>(params_.roughening.angle);
    noise.sigma_along = std::hypot(noise.sigma_along, rt);
    noise.sigma_across = std::hypot(noise.sigma_across, rt);
    noise.sigma_vertical = std::hypot(noise.sigma_vertical, rt);
    noise.sigma_roll = std::hypot(noise.sigma_roll, ra);
    noise.sigma_pitch = std::hypot(noise.sigma_pitch, ra);
    noise.sigma_yaw = std::hypot(noise.sigma_yaw, ra);
  }
  apply_motion(evaluator_.particles(), n, delta, noise, params_.seed, step_);
}

WeightSummary ParticleFilter::Core::weigh_scan(std::size_t n, const std::vector<Eigen::Vector3f>& points,
                                               FilterStep& step) {
  if (points.size() > points_capacity_) {
    points_capacity_ = points.size();
    evaluator_.reserve(capacity_, points_capacity_);
  }
  const Eigen::Quaternionf reference(Eigen::Quaterniond(last_estimate_pose_.linear()).cast<float>());
  UpdateTimings et;
  // A global search until the belief first concentrates (not after a local start): subset first's middle pass.
  const bool global_search = !local_start_ && !concentrated_once();
  const WeightSummary summary =
      subset_first_.weigh(evaluator_, n, points, params_.sensor, reference, &et, global_search);
  step.timings.upload_ms = et.upload_ms;
  step.timings.weight_ms = et.evaluate_ms;
  step.timings.weight_gpu_ms = et.weight_gpu_ms;
  step.timings.reduce_gpu_ms = et.reduce_gpu_ms;
  return summary;
}

void ParticleFilter::Core::read_walls(const std::vector<Eigen::Vector3f>& points, const ScanExtras& extras) {
  scan_normals_.clear();
  scan_points_ = points.size();
  if (params_.places.wall_tilt_information > 0.0) scan_normals_ = planar_normals(extras.dense ? *extras.dense : points);
}

WallTilt ParticleFilter::Core::walls_at(const Pose& pose) {
  if (!(params_.places.wall_tilt_information > 0.0)) return WallTilt{};  // without building the proposal for map_up
  return select_walls(scan_normals_, pose, proposal().map_up().cast<double>(),
                      wall_information(params_.places.wall_tilt_information, scan_points_));
}

void ParticleFilter::Core::temper(std::size_t n, FilterStep& step) {
  const ParticleArrays p = evaluator_.particles();
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(p.log_weight[i])) {
      throw Error("sensor update gave particle " + std::to_string(i) + " a non-finite weight");
    }
  }
  // Freshly injected random particles do not count: they are guesses, not belief, and a floor that grew with them
  // would hand their weight back to them whenever recovery floods a converged set.
  const std::size_t fresh = std::min(injected_end_, n) - std::min(injected_begin_, n);
  const double target = params_.min_ess_ratio * static_cast<double>(fresh < n ? n - fresh : n);
  const Tempering t = tsdf_mcl::temper(prior_log_weight_.data(), p.log_weight, n, target, weights_.data());
  for (std::size_t i = 0; i < n; ++i) post_log_weight_[i] = prior_log_weight_[i] + t.beta * p.log_weight[i];
  if (own_places_ > 0) weigh_within_places(n, t.beta);
  step.tempering = t.beta;
  step.ess = t.ess;
}

double ParticleFilter::Core::belief_fit(std::size_t n, const WeightSummary& summary, std::size_t points) const {
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

}  // namespace tsdf_mcl
