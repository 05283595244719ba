#pragma once
// Pose inputs of a localizer checked against the map they are meant for, one rule for every frontend (tsdf-mcl
// localize, the Python module, the ROS node): a position lies within the map's box, a spread or random walk in
// metres is at most the map's diagonal, an angular spread at most a full turn, heights at most the map's height,
// odometry moves at most the map's diagonal between two scans (and its noise is at most ten times that motion),
// times lie within ROS time's range. A value beyond
// these (1e30 m, 1e300 m) used to reach the filter and come out as an estimate at 1e30 m or as NaN. Each check
// throws Error naming `what` (the parameter or argument) and the bound.
#include <Eigen/Core>
#include <optional>
#include <string>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/filter/particle_init.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

// The length of the map box's diagonal (m): the farthest two points of the map lie apart.
double map_diagonal(const TsdfMap& map);

// A rigid transform (finite, an orthonormal rotation) whose position lies within the map's box.
void check_pose_in_map(const TsdfMap& map, const Pose& pose, const std::string& what);
// Position spreads at most the map's diagonal, angular ones at most a full turn; all finite and non-negative.
void check_spread_for_map(const TsdfMap& map, const LocalInitSpread& spread, const std::string& what);
// The options' pose inputs: the initial pose (init, initial_pose.*), the init_sigma_* spreads, the random walk
// (diffusion_*) and roughening in metres, the height band (init_height_band); the odometry noise alpha1..alpha8 at
// most 10 (noise ten times the motion).
void check_options_for_map(const TsdfMap& map, const LocalizerOptions& options);
// A scan's stamp: finite, within +-limits::kMaxAbsTime.
void check_time(double time, const std::string& what);
// An odometry reading: a rigid transform within +-limits::kMaxAbsPosition that lies at most the map's diagonal from
// `previous` (the reading of the scan before, if any).
void check_odometry(const TsdfMap& map, const Pose& odometry, const std::optional<Pose>& previous,
                    const std::string& what);

}  // namespace tsdf_mcl
