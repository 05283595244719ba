#pragma once
// The map's surfaces as points, for display (the ROS node's latched ~map_cloud, RViz): the centre of every voxel
// within half a voxel of a surface.
#include <cstddef>

#include "tsdf_mcl/core/point_cloud.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

// Every voxel of the map's surface blocks whose distance is within half a voxel of zero, by its centre, in block
// order; beyond `max_points` (0: no limit) every k-th one is kept, spread over the map.
PointCloud map_surface(const TsdfMap& map, std::size_t max_points);

}  // namespace tsdf_mcl
