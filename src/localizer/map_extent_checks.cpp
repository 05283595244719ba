#include "tsdf_mcl/localizer/map_extent_checks.hpp"

#include <cmath>
#include <cstdio>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kFullTurn = 2.0 * M_PI;
// Odometry noise (alpha1..alpha8) at most this many times the motion it comes with: beyond, the noise of one update
// carries particles off any map (alpha3 1e30 put the estimate at 1e29 m, alpha1 1e30 made it NaN).
constexpr double kMaxOdometryNoise = 10.0;

std::string number(double v) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.6g", v);
  return buf;
}

std::string metres(double v) { return number(v) + " m"; }

// A length in metres within [0, max]: finite and non-negative are checked here too, for callers that bypass the
// parameter schema (an initial pose's covariance).
void check_length(double v, double max, const std::string& name, const std::string& bound) {
  if (!(v >= 0.0) || !std::isfinite(v)) throw Error(name + " must be a non-negative number");
  if (v > max) throw Error(name + " " + metres(v) + " is larger than " + bound + " (" + metres(max) + ")");
}

void check_rigid(const Pose& pose, const std::string& what) {
  if (!pose.matrix().allFinite()) throw Error(what + " is not finite (NaN or Inf)");
  if (!is_rotation_matrix(pose.linear())) {
    throw Error(what + " is not a rigid transform: its rotation is not orthonormal with det +1");
  }
}

}  // namespace

double map_diagonal(const TsdfMap& map) { return (map.world_max() - map.world_min()).cast<double>().norm(); }

void check_pose_in_map(const TsdfMap& map, const Pose& pose, const std::string& what) {
  check_rigid(pose, what);
  const Eigen::Vector3d lo = map.world_min().cast<double>(), hi = map.world_max().cast<double>();
  const Eigen::Vector3d t = pose.translation();
  const char* axes[] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a) {
    if (t[a] < lo[a] || t[a] > hi[a]) {
      char buf[160];
      std::snprintf(buf, sizeof(buf), " lies outside the map: %s = %.6g m, the map spans %.3f .. %.3f m", axes[a], t[a],
                    lo[a], hi[a]);
      throw Error(what + buf);
    }
  }
}

void check_spread_for_map(const TsdfMap& map, const LocalInitSpread& spread, const std::string& what) {
  const double diagonal = map_diagonal(map);
  check_length(spread.sigma_xy, diagonal, what + "sigma_xy", "the map's diagonal");
  check_length(spread.sigma_z, diagonal, what + "sigma_z", "the map's diagonal");
  for (const auto& [name, v] :
       {std::pair{"sigma_yaw", spread.sigma_yaw}, {"sigma_roll_pitch", spread.sigma_roll_pitch}}) {
    if (!(v >= 0.0) || !std::isfinite(v) || v > kFullTurn) {
      throw Error(what + name + " must lie in [0, 2 pi] rad, got " + number(v));
    }
  }
}

void check_options_for_map(const TsdfMap& map, const LocalizerOptions& options) {
  const FilterParameters& f = options.filter;
  if (options.initial_pose) check_pose_in_map(map, *options.initial_pose, "the initial pose (init, initial_pose.*)");
  check_spread_for_map(map, f.local_init, "init_");
  const double diagonal = map_diagonal(map);
  check_length(f.motion.diffusion_xy, diagonal, "diffusion_xy", "the map's diagonal");
  const double alphas[] = {f.motion.alpha1, f.motion.alpha2, f.motion.alpha3, f.motion.alpha4,
                           f.motion.alpha5, f.motion.alpha6, f.motion.alpha7, f.motion.alpha8};
  for (int i = 0; i < 8; ++i) {
    if (!(alphas[i] <= kMaxOdometryNoise)) {
      throw Error("alpha" + std::to_string(i + 1) + " " + number(alphas[i]) +
                  " is more than 10: odometry noise ten times the motion is no odometry (--motion_model diffusion "
                  "runs without it)");
    }
  }
  if (f.global_init.use_height_band) {
    const double height = static_cast<double>(map.world_max().z() - map.world_min().z());
    for (const double h : {f.global_init.min_height, f.global_init.max_height}) {
      if (!(std::abs(h) <= height)) {
        throw Error("init_height_band " + metres(h) + " lies beyond the map's height (" + metres(height) + ")");
      }
    }
  }
}

void check_time(double time, const std::string& what) {
  if (!std::isfinite(time) || std::abs(time) > limits::kMaxAbsTime) {
    char buf[96];
    std::snprintf(buf, sizeof(buf), " %.6g s lies beyond +-2^32 s (ROS time's range)", time);
    throw Error(what + buf);
  }
}

void check_odometry(const TsdfMap& map, const Pose& odometry, const std::optional<Pose>& previous,
                    const std::string& what) {
  check_rigid(odometry, what);
  if (odometry.translation().cwiseAbs().maxCoeff() > limits::kMaxAbsPosition) {
    throw Error(what + " lies beyond +-2^28 m (" + metres(odometry.translation().cwiseAbs().maxCoeff()) + ")");
  }
  if (!previous) return;
  const double step = (odometry.translation() - previous->translation()).norm();
  const double diagonal = map_diagonal(map);
  if (step > diagonal) {
    throw Error(what + " moved " + metres(step) + " since the scan before, more than the map's diagonal (" +
                metres(diagonal) + ")");
  }
}

}  // namespace tsdf_mcl
