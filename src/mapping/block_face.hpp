#pragma once
// A block's voxel layer that faces a neighbour: the enclosed-region fills of the mesh and cloud builders weigh the
// signs on the faces of the surface blocks around a region.
#include <Eigen/Core>

#include "block_grid.hpp"

namespace tsdf_mcl {

// Calls f(local index) for the B x B voxels of the layer of a block that faces the block it neighbours: `dir` (+1 or
// -1) is the step along `axis` from that block to this one, so +1 gives this block's layer 0 and -1 its last.
template <typename F>
void for_each_facing_voxel(int axis, int dir, F&& f) {
  Eigen::Vector3i l;
  l[axis] = dir > 0 ? 0 : B - 1;
  for (int i = 0; i < B; ++i) {
    for (int j = 0; j < B; ++j) {
      l[(axis + 1) % 3] = i;
      l[(axis + 2) % 3] = j;
      f(TsdfMap::local_index(l));
    }
  }
}

}  // namespace tsdf_mcl
