#pragma once
// The per-point arithmetic of the sensor update, written once for the CPU evaluator in the same float
// operations, in the same order, as shaders/endpoint_weight.comp, so that both land in the same voxel
// (the library is built with -ffp-contract=off; the shader marks these lines `precise`).
#include <cmath>
#include <cstdint>

#include "tsdf_mcl/endpoint_model.hpp"
#include "tsdf_mcl/sensor_evaluator.hpp"
#include "tsdf_mcl/tsdf_map.hpp"

namespace tsdf_mcl::kernel {

// Raw view of a TsdfMap's buffers, as the shader sees them.
struct MapView {
  const std::uint32_t* coarse = nullptr;
  const std::uint32_t* pool = nullptr;
  float inv_voxel = 0.0f;
  float quant_step = 0.0f;  // metres per quantization unit
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

  // Quantized value of voxel (ix, iy, iz), or kUnknownValue.
  std::int32_t fetch(std::int32_t ix, std::int32_t iy, std::int32_t iz) const {
    // Unsigned wrap-around turns "below the box" into "beyond the box": one compare per axis.
    const std::uint32_t rx = static_cast<std::uint32_t>(ix - min_voxel[0]);
    const std::uint32_t ry = static_cast<std::uint32_t>(iy - min_voxel[1]);
    const std::uint32_t rz = static_cast<std::uint32_t>(iz - min_voxel[2]);
    if (rx >= dims_voxels[0] || ry >= dims_voxels[1] || rz >= dims_voxels[2]) return TsdfMap::kUnknownValue;
    const std::uint32_t cell = (rx >> 3) + dims_blocks[0] * ((ry >> 3) + dims_blocks[1] * (rz >> 3));
    const std::uint32_t entry = coarse[cell];
    if (entry >= TsdfMap::kFreeBlock) return entry == TsdfMap::kFreeBlock ? TsdfMap::kQuantMax : TsdfMap::kUnknownValue;
    const std::uint32_t l = (rx & 7u) + 8u * ((ry & 7u) + 8u * (rz & 7u));
    const std::uint32_t word = pool[entry * static_cast<std::uint32_t>(TsdfMap::kWordsPerBlock) + (l >> 1)];
    return static_cast<std::int16_t>(static_cast<std::uint16_t>((l & 1u) ? (word >> 16) : (word & 0xFFFFu)));
  }
};

// Rotation matrix of a unit quaternion, row-major, in the shader's float expression order.
inline void rotation_matrix(float qw, float qx, float qy, float qz, float r[9]) {
  const float xx = qx * qx, yy = qy * qy, zz = qz * qz;
  const float xy = qx * qy, xz = qx * qz, yz = qy * qz;
  const float wx = qw * qx, wy = qw * qy, wz = qw * qz;
  r[0] = 1.0f - 2.0f * (yy + zz);
  r[1] = 2.0f * (xy - wz);
  r[2] = 2.0f * (xz + wy);
  r[3] = 2.0f * (xy + wz);
  r[4] = 1.0f - 2.0f * (xx + zz);
  r[5] = 2.0f * (yz - wx);
  r[6] = 2.0f * (xz - wy);
  r[7] = 2.0f * (yz + wx);
  r[8] = 1.0f - 2.0f * (xx + yy);
}

// World coordinates of a sensor-frame point, in grid units (world / voxel size).
inline void to_grid(const float r[9], const float t[3], float inv_voxel, float px, float py, float pz, float g[3]) {
  for (int a = 0; a < 3; ++a) {
    const float w = r[3 * a] * px + r[3 * a + 1] * py + r[3 * a + 2] * pz + t[a];
    g[a] = w * inv_voxel;
  }
}

// Nearest-voxel sample: quantized value at the voxel whose centre is closest.
inline std::int32_t sample_nearest(const MapView& map, const float g[3]) {
  return map.fetch(static_cast<std::int32_t>(std::floor(g[0] + 0.5f)), static_cast<std::int32_t>(std::floor(g[1] + 0.5f)),
                   static_cast<std::int32_t>(std::floor(g[2] + 0.5f)));
}

// Trilinear sample renormalized over known corners (TsdfMap::trilinear): returns false if unknown.
inline bool sample_trilinear(const MapView& map, const float g[3], float* distance) {
  const float bx = std::floor(g[0]), by = std::floor(g[1]), bz = std::floor(g[2]);
  const float fx = g[0] - bx, fy = g[1] - by, fz = g[2] - bz;
  const auto ix = static_cast<std::int32_t>(bx), iy = static_cast<std::int32_t>(by), iz = static_cast<std::int32_t>(bz);
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

// Float constants of the model, as passed to the shader.
struct ModelConstants {
  float hit_scale;       // z_hit / (sigma sqrt(2 pi))
  float neg_inv_2s2;     // -1 / (2 sigma^2)
  float p_rand;          // z_rand / max_range
  float log_p_rand;
  explicit ModelConstants(const EndpointModel& m)
      : hit_scale(static_cast<float>(m.hit_scale())),
        neg_inv_2s2(-0.5f / (m.sigma_hit * m.sigma_hit)),
        p_rand(static_cast<float>(m.p_rand())),
        log_p_rand(static_cast<float>(std::log(m.p_rand()))) {}
  float likelihood(float d) const { return hit_scale * std::exp(d * d * neg_inv_2s2) + p_rand; }
};

}  // namespace tsdf_mcl::kernel
