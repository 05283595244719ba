#include "tsdf_mcl/cpu/endpoint_avx2.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>

namespace tsdf_mcl::kernel {

#if defined(__x86_64__)

bool avx2_available() { return __builtin_cpu_supports("avx2"); }

namespace {

// Unsigned a < b for 32-bit lanes (AVX2 only compares signed): flip the sign bits first.
__attribute__((target("avx2"))) inline __m256i less_unsigned(__m256i a, __m256i b) {
  const __m256i sign = _mm256_set1_epi32(static_cast<int>(0x80000000u));
  return _mm256_cmpgt_epi32(_mm256_xor_si256(b, sign), _mm256_xor_si256(a, sign));
}

}  // namespace

__attribute__((target("avx2"))) void accumulate_nearest_avx2(const MapView& map, const float* table,
                                                             const ParticleArrays& p, std::size_t begin,
                                                             std::size_t end, const float* points,
                                                             std::size_t point_count, float* acc_out) {
  const __m256i min_x = _mm256_set1_epi32(map.min_voxel[0]);
  const __m256i min_y = _mm256_set1_epi32(map.min_voxel[1]);
  const __m256i min_z = _mm256_set1_epi32(map.min_voxel[2]);
  const __m256i dims_x = _mm256_set1_epi32(static_cast<int>(map.dims_voxels[0]));
  const __m256i dims_y = _mm256_set1_epi32(static_cast<int>(map.dims_voxels[1]));
  const __m256i dims_z = _mm256_set1_epi32(static_cast<int>(map.dims_voxels[2]));
  const __m256i blocks_x = _mm256_set1_epi32(static_cast<int>(map.dims_blocks[0]));
  const __m256i blocks_y = _mm256_set1_epi32(static_cast<int>(map.dims_blocks[1]));
  const __m256i seven = _mm256_set1_epi32(7);
  const __m256i one = _mm256_set1_epi32(1);
  const __m256i all = _mm256_set1_epi32(-1);
  const __m256i free_entry = _mm256_set1_epi32(static_cast<int>(TsdfMap::kFreeBlock));
  const __m256i q_free = _mm256_set1_epi32(TsdfMap::kQuantMax);
  const __m256i q_unknown = _mm256_set1_epi32(TsdfMap::kUnknownValue);
  const __m256i table_offset = _mm256_set1_epi32(32768);
  const __m256 inv_voxel = _mm256_set1_ps(map.inv_voxel);
  const __m256 half = _mm256_set1_ps(0.5f);
  const __m256 lo = _mm256_set1_ps(-1.0e9f);
  const __m256 hi = _mm256_set1_ps(1.0e9f);
  const auto* coarse = reinterpret_cast<const int*>(map.coarse);
  const auto* pool = reinterpret_cast<const int*>(map.pool);

  for (std::size_t i = begin; i < end; i += 8) {
    alignas(32) float rows[12][8];
    for (std::size_t k = 0; k < 8; ++k) {
      const std::size_t s = std::min(i + k, end - 1);  // a short last group repeats its last particle
      float r[9];
      rotation_matrix(p.qw[s], p.qx[s], p.qy[s], p.qz[s], r);
      for (int a = 0; a < 9; ++a) rows[a][k] = r[a];
      rows[9][k] = p.x[s];
      rows[10][k] = p.y[s];
      rows[11][k] = p.z[s];
    }
    __m256 r[12];
    for (int a = 0; a < 12; ++a) r[a] = _mm256_load_ps(rows[a]);
    __m256 acc = _mm256_setzero_ps();
    for (std::size_t j = 0; j < point_count; ++j) {
      const __m256 px = _mm256_set1_ps(points[3 * j]);
      const __m256 py = _mm256_set1_ps(points[3 * j + 1]);
      const __m256 pz = _mm256_set1_ps(points[3 * j + 2]);
      __m256i v[3];
      for (int a = 0; a < 3; ++a) {
        // ((r0 px + r1 py) + r2 pz) + t, then * inv_voxel + 0.5: the scalar path's order, no FMA.
        const __m256 w =
            _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(r[3 * a], px), _mm256_mul_ps(r[3 * a + 1], py)),
                                        _mm256_mul_ps(r[3 * a + 2], pz)),
                          r[9 + a]);
        const __m256 g = _mm256_add_ps(_mm256_mul_ps(w, inv_voxel), half);
        v[a] = _mm256_cvttps_epi32(_mm256_floor_ps(_mm256_min_ps(_mm256_max_ps(g, lo), hi)));
      }
      const __m256i rx = _mm256_sub_epi32(v[0], min_x);
      const __m256i ry = _mm256_sub_epi32(v[1], min_y);
      const __m256i rz = _mm256_sub_epi32(v[2], min_z);
      const __m256i inside = _mm256_and_si256(_mm256_and_si256(less_unsigned(rx, dims_x), less_unsigned(ry, dims_y)),
                                              less_unsigned(rz, dims_z));
      const __m256i cell = _mm256_add_epi32(
          _mm256_srli_epi32(rx, 3),
          _mm256_mullo_epi32(blocks_x, _mm256_add_epi32(_mm256_srli_epi32(ry, 3),
                                                        _mm256_mullo_epi32(blocks_y, _mm256_srli_epi32(rz, 3)))));
      const __m256i entry = _mm256_mask_i32gather_epi32(all, coarse, _mm256_and_si256(cell, inside), inside, 4);
      const __m256i sentinel = less_unsigned(_mm256_set1_epi32(static_cast<int>(TsdfMap::kFreeBlock - 1)), entry);
      const __m256i l = _mm256_add_epi32(
          _mm256_and_si256(rx, seven),
          _mm256_slli_epi32(
              _mm256_add_epi32(_mm256_and_si256(ry, seven), _mm256_slli_epi32(_mm256_and_si256(rz, seven), 3)), 3));
      const __m256i word_index = _mm256_add_epi32(_mm256_slli_epi32(entry, 8), _mm256_srli_epi32(l, 1));
      const __m256i word =
          _mm256_mask_i32gather_epi32(_mm256_setzero_si256(), pool, word_index, _mm256_andnot_si256(sentinel, all), 4);
      // The voxel's int16 half of the word, sign-extended.
      const __m256i shift = _mm256_slli_epi32(_mm256_and_si256(l, one), 4);
      const __m256i value = _mm256_srai_epi32(_mm256_slli_epi32(_mm256_srlv_epi32(word, shift), 16), 16);
      const __m256i sentinel_value = _mm256_blendv_epi8(q_unknown, q_free, _mm256_cmpeq_epi32(entry, free_entry));
      const __m256i q = _mm256_blendv_epi8(value, sentinel_value, sentinel);
      acc = _mm256_add_ps(acc, _mm256_i32gather_ps(table, _mm256_add_epi32(q, table_offset), 4));
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
