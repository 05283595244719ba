#pragma once
// An operator's pose on the floor plan (RViz's "2D Pose Estimate", a ROS /initialpose with z, roll and pitch left
// 0: x, y and yaw only) made 6-DoF from the map and the latest scan. The scan gives the up direction in the sensor
// frame (roll and pitch) and the sensor's height above the floor; the map gives the floors under (x, y).
#include <Eigen/Core>
#include <optional>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

// Heights (m) of the upward-facing surfaces under (x, y), lowest first: where the column of voxels changes from
// occupied (below) to free (above), at the zero crossing.
std::vector<double> floors_under(const TsdfMap& map, double x, double y);

// world_T_base at (x, y, yaw) with roll, pitch and z completed: `scan` is the latest scan in its sensor's frame,
// mounted at `base_T_sensor` on the base (whose +z points up, REP 103: that picks up from down among the scan's
// candidates). Of several floors under (x, y) (storeys, a ramp above a floor) the one that puts the base nearest
// to `z_hint` (the current estimate), else the lowest. nullopt where the scan shows no floor or the map has none
// under (x, y).
std::optional<Pose> pose_from_planar(const TsdfMap& map, double x, double y, double yaw,
                                     const std::vector<Eigen::Vector3f>& scan, const Pose& base_T_sensor,
                                     std::optional<double> z_hint = std::nullopt);

}  // namespace tsdf_mcl
