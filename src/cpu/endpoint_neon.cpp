#include "tsdf_mcl/cpu/endpoint_neon.hpp"

#if defined(__aarch64__)
#include <arm_neon.h>
#endif

#include <algorithm>
#include <cstdint>

namespace tsdf_mcl::kernel {

#if defined(__aarch64__)

bool neon_available() { return true; }

namespace {

// Quantized value per lane from the lanes' block-relative coordinates, as MapView::fetch reads it: the sentinel
// blocks stand in for free and unknown cells so no lane branches on what it hits.
inline void fetch_lanes(const MapView& map, uint32x4_t inside, uint32x4_t cell, uint32x4_t local, std::int32_t out[4]) {
  alignas(16) std::uint32_t in[4], c[4], l[4];
  vst1q_u32(in, inside);
  vst1q_u32(c, vandq_u32(cell, inside));  // outside lanes read cell 0 (in bounds), then discard it
  vst1q_u32(l, local);
  std::uint32_t entry[4];
  for (int k = 0; k < 4; ++k) entry[k] = map.coarse[c[k]];
  for (int k = 0; k < 4; ++k) {
    const std::uint32_t e = in[k] != 0 ? entry[k] : TsdfMap::kUnknownBlock;
    const std::uint32_t* block = e >= TsdfMap::kFreeBlock
                                     ? kSentinelBlocks.words[e - TsdfMap::kFreeBlock]
                                     : map.pool + static_cast<std::size_t>(e) * TsdfMap::kWordsPerBlock;
    out[k] = static_cast<std::int16_t>(static_cast<std::uint16_t>(block[l[k] >> 1] >> ((l[k] & 1u) << 4)));
  }
}

}  // namespace

void accumulate_nearest_neon(const MapView& map, const float* table, const ParticleArrays& p, std::size_t begin,
                             std::size_t end, const float* points, std::size_t point_count, float* acc_out) {
  const int32x4_t min_x = vdupq_n_s32(map.min_voxel[0]);
  const int32x4_t min_y = vdupq_n_s32(map.min_voxel[1]);
  const int32x4_t min_z = vdupq_n_s32(map.min_voxel[2]);
  const uint32x4_t dims_x = vdupq_n_u32(map.dims_voxels[0]);
  const uint32x4_t dims_y = vdupq_n_u32(map.dims_voxels[1]);
  const uint32x4_t dims_z = vdupq_n_u32(map.dims_voxels[2]);
  const uint32x4_t blocks_x = vdupq_n_u32(map.dims_blocks[0]);
  const uint32x4_t blocks_y = vdupq_n_u32(map.dims_blocks[1]);
  const uint32x4_t seven = vdupq_n_u32(7);
  const float32x4_t inv_voxel = vdupq_n_f32(map.inv_voxel);
  const float32x4_t half = vdupq_n_f32(0.5f);
  const float32x4_t lo = vdupq_n_f32(-1.0e9f);
  const float32x4_t hi = vdupq_n_f32(1.0e9f);
  const float* centred = table + 32768;

  for (std::size_t i = begin; i < end; i += 4) {
    alignas(16) float rows[12][4];
    pose_lanes(p, i, end, rows);
    float32x4_t r[12];
    for (int a = 0; a < 12; ++a) r[a] = vld1q_f32(rows[a]);
    float32x4_t acc = vdupq_n_f32(0.0f);
    for (std::size_t j = 0; j < point_count; ++j) {
      const float32x4_t px = vdupq_n_f32(points[3 * j]);
      const float32x4_t py = vdupq_n_f32(points[3 * j + 1]);
      const float32x4_t pz = vdupq_n_f32(points[3 * j + 2]);
      int32x4_t v[3];
      for (int a = 0; a < 3; ++a) {
        // ((r0 px + r1 py) + r2 pz) + t, then * inv_voxel + 0.5: the scalar path's order, no FMA (separate
        // vmulq/vaddq; the layers build with -ffp-contract=off so the compiler does not fuse them either).
        const float32x4_t w = vaddq_f32(
            vaddq_f32(vaddq_f32(vmulq_f32(r[3 * a], px), vmulq_f32(r[3 * a + 1], py)), vmulq_f32(r[3 * a + 2], pz)),
            r[9 + a]);
        const float32x4_t g = vaddq_f32(vmulq_f32(w, inv_voxel), half);
        // floor_int: clamp, then round toward minus infinity (vrndmq) and convert exactly.
        v[a] = vcvtq_s32_f32(vrndmq_f32(vminq_f32(vmaxq_f32(g, lo), hi)));
      }
      // Unsigned wrap-around turns "below the box" into "beyond the box", as in MapView::fetch.
      const uint32x4_t rx = vreinterpretq_u32_s32(vsubq_s32(v[0], min_x));
      const uint32x4_t ry = vreinterpretq_u32_s32(vsubq_s32(v[1], min_y));
      const uint32x4_t rz = vreinterpretq_u32_s32(vsubq_s32(v[2], min_z));
      const uint32x4_t inside =
          vandq_u32(vandq_u32(vcltq_u32(rx, dims_x), vcltq_u32(ry, dims_y)), vcltq_u32(rz, dims_z));
      const uint32x4_t cell =
          vaddq_u32(vshrq_n_u32(rx, 3),
                    vmulq_u32(blocks_x, vaddq_u32(vshrq_n_u32(ry, 3), vmulq_u32(blocks_y, vshrq_n_u32(rz, 3)))));
      const uint32x4_t local = vaddq_u32(
          vandq_u32(rx, seven), vshlq_n_u32(vaddq_u32(vandq_u32(ry, seven), vshlq_n_u32(vandq_u32(rz, seven), 3)), 3));
      std::int32_t q[4];
      fetch_lanes(map, inside, cell, local, q);
      const float terms[4] = {centred[q[0]], centred[q[1]], centred[q[2]], centred[q[3]]};
      acc = vaddq_f32(acc, vld1q_f32(terms));
    }
    alignas(16) float lanes[4];
    vst1q_f32(lanes, acc);
    for (std::size_t k = 0; k < 4 && i + k < end; ++k) acc_out[i + k] = lanes[k];
  }
}

#else

bool neon_available() { return false; }

void accumulate_nearest_neon(const MapView&, const float*, const ParticleArrays&, std::size_t, std::size_t,
                             const float*, std::size_t, float*) {}

#endif

}  // namespace tsdf_mcl::kernel
