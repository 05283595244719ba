#include "tsdf_mcl/cpu/endpoint_avx2.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>

namespace tsdf_mcl::kernel {

#if defined(__x86_64__)

bool avx2_available() { return __builtin_cpu_supports("avx2"); }

namespace {

// Points per batch: each pass below runs over a batch before the next pass starts (Batch: 10 KB, stays in L1).
constexpr std::size_t kBatch = 64;

// Unsigned a < b for 32-bit lanes (AVX2 only compares signed): flip the sign bits first.
__attribute__((target("avx2"))) inline __m256i less_unsigned(__m256i a, __m256i b) {
  const __m256i sign = _mm256_set1_epi32(static_cast<int>(0x80000000u));
  return _mm256_cmpgt_epi32(_mm256_xor_si256(b, sign), _mm256_xor_si256(a, sign));
}

// Eight particles' poses, one lane each: rotation rows r[0..8], translation r[9..11].
struct Poses {
  __m256 r[12];
};

__attribute__((target("avx2"))) Poses load_poses(const ParticleArrays& p, std::size_t i, std::size_t end) {
  alignas(32) float rows[12][8];
  pose_lanes(p, i, end, rows);
  Poses poses;
  for (int a = 0; a < 12; ++a) poses.r[a] = _mm256_load_ps(rows[a]);
  return poses;
}

// Per point of a batch and lane: the coarse cell (0 outside the map), whether it is inside, the voxel within
// its block, then the coarse entry, then the table index of the voxel's quantized distance.
struct Batch {
  __m256i cell[kBatch];
  __m256i inside[kBatch];
  __m256i voxel[kBatch];
  __m256i entry[kBatch];
  __m256i term[kBatch];
};

// Pass 1, arithmetic only: where each point lands, for eight poses.
__attribute__((target("avx2"))) void locate(const MapView& map, const Poses& pose, const float* points,
                                            std::size_t count, Batch& b) {
  const __m256 inv_voxel = _mm256_set1_ps(map.inv_voxel);
  const __m256i seven = _mm256_set1_epi32(7);
  const __m256i blocks_x = _mm256_set1_epi32(static_cast<int>(map.dims_blocks[0]));
  const __m256i blocks_y = _mm256_set1_epi32(static_cast<int>(map.dims_blocks[1]));
  for (std::size_t j = 0; j < count; ++j) {
    const __m256 px = _mm256_set1_ps(points[3 * j]);
    const __m256 py = _mm256_set1_ps(points[3 * j + 1]);
    const __m256 pz = _mm256_set1_ps(points[3 * j + 2]);
    __m256i rel[3];
    __m256i inside = _mm256_set1_epi32(-1);
    for (int a = 0; a < 3; ++a) {
      // ((r0 px + r1 py) + r2 pz) + t, then * inv_voxel + 0.5: the scalar path's order, no FMA.
      const __m256 w = _mm256_add_ps(
          _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(pose.r[3 * a], px), _mm256_mul_ps(pose.r[3 * a + 1], py)),
                        _mm256_mul_ps(pose.r[3 * a + 2], pz)),
          pose.r[9 + a]);
      const __m256 g = _mm256_add_ps(_mm256_mul_ps(w, inv_voxel), _mm256_set1_ps(0.5f));
      const __m256 clamped = _mm256_min_ps(_mm256_max_ps(g, _mm256_set1_ps(-1.0e9f)), _mm256_set1_ps(1.0e9f));
      rel[a] = _mm256_sub_epi32(_mm256_cvttps_epi32(_mm256_floor_ps(clamped)), _mm256_set1_epi32(map.min_voxel[a]));
      inside = _mm256_and_si256(inside, less_unsigned(rel[a], _mm256_set1_epi32(static_cast<int>(map.dims_voxels[a]))));
    }
    const __m256i cell = _mm256_add_epi32(
        _mm256_srli_epi32(rel[0], 3),
        _mm256_mullo_epi32(blocks_x, _mm256_add_epi32(_mm256_srli_epi32(rel[1], 3),
                                                      _mm256_mullo_epi32(blocks_y, _mm256_srli_epi32(rel[2], 3)))));
    b.cell[j] = _mm256_and_si256(cell, inside);
    b.inside[j] = inside;
    b.voxel[j] = _mm256_add_epi32(
        _mm256_and_si256(rel[0], seven),
        _mm256_slli_epi32(
            _mm256_add_epi32(_mm256_and_si256(rel[1], seven), _mm256_slli_epi32(_mm256_and_si256(rel[2], seven), 3)),
            3));
  }
}

// Pass 3: the voxels' quantized values (sentinel blocks read as their constant), as table indices.
__attribute__((target("avx2"))) void read_voxels(const MapView& map, std::size_t count, Batch& b) {
  const __m256i one = _mm256_set1_epi32(1);
  const __m256i all = _mm256_set1_epi32(-1);
  const __m256i free_entry = _mm256_set1_epi32(static_cast<int>(TsdfMap::kFreeBlock));
  const __m256i last_block = _mm256_set1_epi32(static_cast<int>(TsdfMap::kFreeBlock - 1));
  const __m256i q_free = _mm256_set1_epi32(TsdfMap::kQuantMax);
  const __m256i q_unknown = _mm256_set1_epi32(TsdfMap::kUnknownValue);
  const __m256i table_offset = _mm256_set1_epi32(32768);
  const auto* pool = reinterpret_cast<const int*>(map.pool);
  for (std::size_t j = 0; j < count; ++j) {
    const __m256i entry = b.entry[j];
    const __m256i l = b.voxel[j];
    const __m256i sentinel = less_unsigned(last_block, entry);
    const __m256i word_index = _mm256_add_epi32(_mm256_slli_epi32(entry, 8), _mm256_srli_epi32(l, 1));
    const __m256i word =
        _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), pool, word_index, _mm256_andnot_si256(sentinel, all), 4);
    // The voxel's int16 half of the word, sign-extended.
    const __m256i shift = _mm256_slli_epi32(_mm256_and_si256(l, one), 4);
    const __m256i value = _mm256_srai_epi32(_mm256_slli_epi32(_mm256_srlv_epi32(word, shift), 16), 16);
    const __m256i sentinel_value = _mm256_blendv_epi8(q_unknown, q_free, _mm256_cmpeq_epi32(entry, free_entry));
    b.term[j] = _mm256_add_epi32(_mm256_blendv_epi8(value, sentinel_value, sentinel), table_offset);
  }
}

}  // namespace

// The work per batch of points is split in four passes (locate, coarse gathers, pool gathers, table gathers) so
// that each gather loop is short: many more of the cache-missing gathers fit in the CPU's reorder window at once,
// where one long loop body per point left one point's misses waiting before the next point's could start (perf:
// two thirds of the time stalled on the pool gather). The terms are still added in point order.
__attribute__((target("avx2"))) void accumulate_nearest_avx2(const MapView& map, const float* table,
                                                             const ParticleArrays& p, std::size_t begin,
                                                             std::size_t end, const float* points,
                                                             std::size_t point_count, float* acc_out) {
  const auto* coarse = reinterpret_cast<const int*>(map.coarse);
  const __m256i all = _mm256_set1_epi32(-1);
  alignas(32) Batch batch;
  for (std::size_t i = begin; i < end; i += 8) {
    const Poses pose = load_poses(p, i, end);
    __m256 acc = _mm256_setzero_ps();
    for (std::size_t j0 = 0; j0 < point_count; j0 += kBatch) {
      const std::size_t count = std::min(kBatch, point_count - j0);
      locate(map, pose, points + 3 * j0, count, batch);
      for (std::size_t j = 0; j < count; ++j) {  // pass 2: outside the map reads as the unknown entry
        batch.entry[j] = _mm256_mask_i32gather_epi32(all, coarse, batch.cell[j], batch.inside[j], 4);
      }
      read_voxels(map, count, batch);
      for (std::size_t j = 0; j < count; ++j) acc = _mm256_add_ps(acc, _mm256_i32gather_ps(table, batch.term[j], 4));
    }
    alignas(32) float lanes[8];
    _mm256_store_ps(lanes, acc);
    for (std::size_t k = 0; k < 8 && i + k < end; ++k) acc_out[i + k] = lanes[k];
  }
}

#else

bool avx2_available() { return false; }

void accumulate_nearest_avx2(const MapView&, const float*, const ParticleArrays&, std::size_t, std::size_t,
                             const float*, std::size_t, float*) {}

#endif

}  // namespace tsdf_mcl::kernel
