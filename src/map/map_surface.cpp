#include "tsdf_mcl/map/map_surface.hpp"

#include <cmath>
#include <optional>

namespace tsdf_mcl {

PointCloud map_surface(const TsdfMap& map, std::size_t max_points) {
  PointCloud surface;
  const float band = 0.5f * map.voxel_size();
  const Eigen::Vector3i dims = map.dims_blocks();
  for (int bz = 0; bz < dims.z(); ++bz) {
    for (int by = 0; by < dims.y(); ++by) {
      for (int bx = 0; bx < dims.x(); ++bx) {
        const Eigen::Vector3i block = map.min_block() + Eigen::Vector3i(bx, by, bz);
        const std::uint32_t entry = map.block_entry(block);
        if (entry == TsdfMap::kUnknownBlock || entry == TsdfMap::kFreeBlock) continue;
        for (int i = 0; i < TsdfMap::kVoxelsPerBlock; ++i) {
          const Eigen::Vector3i v =
              block * TsdfMap::kBlockSize + Eigen::Vector3i(i % TsdfMap::kBlockSize,
                                                            (i / TsdfMap::kBlockSize) % TsdfMap::kBlockSize,
                                                            i / (TsdfMap::kBlockSize * TsdfMap::kBlockSize));
          const std::optional<float> d = map.distance(v);
          if (d && std::abs(*d) <= band) surface.points.push_back(map.center_of(v));
        }
      }
    }
  }
  if (max_points > 0 && surface.points.size() > max_points) {
    const std::size_t keep_every = (surface.points.size() + max_points - 1) / max_points;
    std::size_t kept = 0;
    for (std::size_t i = 0; i < surface.points.size(); i += keep_every) surface.points[kept++] = surface.points[i];
    surface.points.resize(kept);
  }
  return surface;
}

}  // namespace tsdf_mcl
