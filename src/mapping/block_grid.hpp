#pragma once
// The block grid's sizes under the short names the builders' voxel loops use.
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

inline constexpr int B = TsdfMap::kBlockSize;             // voxels along a block's edge
inline constexpr int kVoxels = TsdfMap::kVoxelsPerBlock;  // voxels in a block

}  // namespace tsdf_mcl
