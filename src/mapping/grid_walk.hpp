#pragma once
// Walking a segment through the voxel grid or the block grid (Amanatides & Woo), shared by the scan integrator and
// the cloud builder.
#include <Eigen/Core>
#include <cmath>
#include <limits>

namespace tsdf_mcl::grid {

using Eigen::Vector3f;
using Eigen::Vector3i;

// The cells of a grid that the segment origin + t*dir, t in [t0, t1], passes through, in order (Amanatides & Woo):
// visit(cell, t_in, t_out) until it returns false. Cells are `scale` voxels wide and aligned with the voxel grid
// (scale 1: voxels, scale kBlockSize: blocks); voxel v spans [v - 1/2, v + 1/2) * voxel on each axis. Returns false
// if visit stopped the walk.
template <typename Visit>
bool walk_until(const Vector3f& origin, const Vector3f& dir, float t0, float t1, float voxel, int scale,
                Visit&& visit) {
  const float size = voxel * static_cast<float>(scale);
  const Vector3f g = ((origin + t0 * dir) / voxel + Vector3f::Constant(0.5f)) / static_cast<float>(scale);
  Vector3i c(static_cast<int>(std::floor(g.x())), static_cast<int>(std::floor(g.y())),
             static_cast<int>(std::floor(g.z())));
  Vector3i step;
  Vector3f t_max, t_delta;
  for (int a = 0; a < 3; ++a) {
    if (dir[a] > 0.0f) {
      step[a] = 1;
      t_delta[a] = size / dir[a];
      t_max[a] = t0 + (static_cast<float>(c[a] + 1) - g[a]) * t_delta[a];
    } else if (dir[a] < 0.0f) {
      step[a] = -1;
      t_delta[a] = -size / dir[a];
      t_max[a] = t0 + (g[a] - static_cast<float>(c[a])) * t_delta[a];
    } else {
      step[a] = 0;
      t_delta[a] = std::numeric_limits<float>::infinity();
      t_max[a] = std::numeric_limits<float>::infinity();
    }
  }
  float t_in = t0;
  while (true) {
    const int a = t_max.x() < t_max.y() ? (t_max.x() < t_max.z() ? 0 : 2) : (t_max.y() < t_max.z() ? 1 : 2);
    if (!visit(c, t_in, std::min(t_max[a], t1))) return false;
    if (t_max[a] >= t1) return true;
    t_in = t_max[a];
    c[a] += step[a];
    t_max[a] += t_delta[a];
  }
}

// As walk_until(), visiting every cell: visit(cell, t_in, t_out) returns nothing.
template <typename Visit>
void walk(const Vector3f& origin, const Vector3f& dir, float t0, float t1, float voxel, int scale, Visit&& visit) {
  walk_until(origin, dir, t0, t1, voxel, scale, [&](const Vector3i& c, float t_in, float t_out) {
    visit(c, t_in, t_out);
    return true;
  });
}

}  // namespace tsdf_mcl::grid
