#pragma once
// The map's lookup, written once: the nearest and trilinear samples of a TsdfMap's buffers as the sensor update
// reads them (TsdfMap::nearest/trilinear, the CPU evaluator, the filter's scan fit and the global search all call
// these). The shader's fetch() in shaders/endpoint_weight.comp mirrors MapView::fetch and sample_nearest
// (same sentinel handling, same floor of g + 0.5); the block layout's constants are in shaders/map_layout.glsl.
#include <algorithm>
#include <cstdint>

#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::kernel {

// Blocks that free (index 0) and unknown (index 1) coarse entries read from, so lookups need no branches.
struct SentinelBlocks {
  std::uint32_t words[2][TsdfMap::kWordsPerBlock];
};
constexpr SentinelBlocks make_sentinel_blocks() {
  SentinelBlocks b{};
  for (int w = 0; w < TsdfMap::kWordsPerBlock; ++w) {
    b.words[0][w] = static_cast<std::uint32_t>(TsdfMap::kQuantMax) * 0x10001u;
    b.words[1][w] = static_cast<std::uint32_t>(static_cast<std::uint16_t>(TsdfMap::kUnknownValue)) * 0x10001u;
  }
  return b;
}
inline constexpr SentinelBlocks kSentinelBlocks = make_sentinel_blocks();

// Raw view of a TsdfMap's buffers, as the shader sees them.
struct MapView {
  const std::uint32_t* coarse = nullptr;
  const std::uint32_t* pool = nullptr;
  float inv_voxel = 0.0f;
  float quant_step = 0.0f;                // metres per quantization unit
  std::int32_t min_voxel[3] = {0, 0, 0};  // first voxel of the block box
  std::uint32_t dims_voxels[3] = {0, 0, 0};
  std::uint32_t dims_blocks[3] = {0, 0, 0};

  explicit MapView(const TsdfMap& map)
      : coarse(map.coarse_index().data()),
        pool(map.block_pool().data()),
        inv_voxel(1.0f / map.voxel_size()),
        quant_step(map.quantization_step()) {
    for (int a = 0; a < 3; ++a) {
      min_voxel[a] = map.min_block()[a] * TsdfMap::kBlockSize;
      dims_blocks[a] = static_cast<std::uint32_t>(map.dims_blocks()[a]);
      dims_voxels[a] = dims_blocks[a] * TsdfMap::kBlockSize;
    }
  }

  // Quantized value of voxel (ix, iy, iz), or kUnknownValue. Branch-free like the shader's fetch(): the
  // sentinels point at two constant blocks, so the hot loop has no unpredictable branches.
  std::int32_t fetch(std::int32_t ix, std::int32_t iy, std::int32_t iz) const {
    // Unsigned wrap-around turns "below the box" into "beyond the box": one compare per axis.
    const std::uint32_t rx = static_cast<std::uint32_t>(ix - min_voxel[0]);
    const std::uint32_t ry = static_cast<std::uint32_t>(iy - min_voxel[1]);
    const std::uint32_t rz = static_cast<std::uint32_t>(iz - min_voxel[2]);
    const bool inside = (rx < dims_voxels[0]) & (ry < dims_voxels[1]) & (rz < dims_voxels[2]);
    const std::uint32_t cell = inside ? (rx >> 3) + dims_blocks[0] * ((ry >> 3) + dims_blocks[1] * (rz >> 3)) : 0u;
    const std::uint32_t entry = inside ? coarse[cell] : TsdfMap::kUnknownBlock;
    const std::uint32_t* block = entry >= TsdfMap::kFreeBlock
                                     ? kSentinelBlocks.words[entry - TsdfMap::kFreeBlock]
                                     : pool + static_cast<std::size_t>(entry) * TsdfMap::kWordsPerBlock;
    const std::uint32_t l = (rx & 7u) + 8u * ((ry & 7u) + 8u * (rz & 7u));
    return static_cast<std::int16_t>(static_cast<std::uint16_t>(block[l >> 1] >> ((l & 1u) << 4)));
  }
};

// floor() as an integer without a libm call (baseline x86-64 has no rounding instruction); equal to the shader's
// floor for every grid coordinate a map can hold (|v| < 2^30, clamped beyond: outside every map anyway).
inline std::int32_t floor_int(float v) {
  v = std::min(std::max(v, -1.0e9f), 1.0e9f);
  const auto i = static_cast<std::int32_t>(v);
  return i - (v < static_cast<float>(i) ? 1 : 0);
}

// Nearest-voxel sample: quantized value at the voxel whose centre is closest.
inline std::int32_t sample_nearest(const MapView& map, const float g[3]) {
  return map.fetch(floor_int(g[0] + 0.5f), floor_int(g[1] + 0.5f), floor_int(g[2] + 0.5f));
}

// Trilinear sample renormalized over known corners (TsdfMap::trilinear): returns false if unknown.
inline bool sample_trilinear(const MapView& map, const float g[3], float* distance) {
  const std::int32_t ix = floor_int(g[0]), iy = floor_int(g[1]), iz = floor_int(g[2]);
  const float fx = g[0] - static_cast<float>(ix), fy = g[1] - static_cast<float>(iy),
              fz = g[2] - static_cast<float>(iz);
  float weight = 0.0f;
  float sum = 0.0f;
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = corner & 1, dy = (corner >> 1) & 1, dz = (corner >> 2) & 1;
    const std::int32_t q = map.fetch(ix + dx, iy + dy, iz + dz);
    if (q == TsdfMap::kUnknownValue) continue;
    const float w = (dx ? fx : 1.0f - fx) * (dy ? fy : 1.0f - fy) * (dz ? fz : 1.0f - fz);
    weight += w;
    sum += w * static_cast<float>(q);
  }
  if (weight < 1e-3f) return false;
  *distance = sum / weight * map.quant_step;
  return true;
}

}  // namespace tsdf_mcl::kernel
