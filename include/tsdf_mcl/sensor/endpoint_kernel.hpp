#pragma once
// The per-point arithmetic of the sensor update, written once: the transform of a scan point into the map and the
// endpoint model's likelihood, in the same float operations and order as shaders/endpoint_weight.comp
// (its GLSL mirror: shaders/endpoint_model.glsl), so that CPU and GPU land in the same voxel and agree to
// float tolerance (every layer is built with -ffp-contract=off; the shader marks these lines `precise`). The map
// lookup itself is tsdf_mcl/map/map_lookup.hpp.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "tsdf_mcl/sensor/endpoint_model.hpp"
#include "tsdf_mcl/map/map_lookup.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl::kernel {

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

// The poses of particles [i, i + Lanes) transposed for SIMD lanes: rows[a][k] holds, for a < 9, the rotation
// matrix's entries (row-major) and, for a = 9..11, the position; a short last group repeats particle end - 1.
template <std::size_t Lanes>
inline void pose_lanes(const ParticleArrays& p, std::size_t i, std::size_t end, float (&rows)[12][Lanes]) {
  for (std::size_t k = 0; k < Lanes; ++k) {
    const std::size_t s = std::min(i + k, end - 1);
    float r[9];
    rotation_matrix(p.qw[s], p.qx[s], p.qy[s], p.qz[s], r);
    for (int a = 0; a < 9; ++a) rows[a][k] = r[a];
    rows[9][k] = p.x[s];
    rows[10][k] = p.y[s];
    rows[11][k] = p.z[s];
  }
}

// World coordinates of a sensor-frame point, in grid units (world / voxel size).
inline void to_grid(const float r[9], const float t[3], float inv_voxel, float px, float py, float pz, float g[3]) {
  for (int a = 0; a < 3; ++a) {
    const float w = r[3 * a] * px + r[3 * a + 1] * py + r[3 * a + 2] * pz + t[a];
    g[a] = w * inv_voxel;
  }
}

// Float constants of the model, as passed to the shader.
struct ModelConstants {
  float hit_scale;    // z_hit / (sigma sqrt(2 pi))
  float neg_inv_2s2;  // -1 / (2 sigma^2)
  float p_rand;       // z_rand / max_range
  float p_unknown;    // a point in unknown space (EndpointModel::unknown_distance)
  float log_p_unknown;
  explicit ModelConstants(const EndpointModel& m)
      : hit_scale(static_cast<float>(m.hit_scale())),
        neg_inv_2s2(-0.5f / (m.sigma_hit * m.sigma_hit)),
        p_rand(static_cast<float>(m.p_rand())),
        p_unknown(static_cast<float>(m.p_unknown())),
        log_p_unknown(static_cast<float>(std::log(m.p_unknown()))) {}
  float likelihood(float d) const { return hit_scale * std::exp(d * d * neg_inv_2s2) + p_rand; }
};

constexpr std::size_t kTableSize = 65536;  // one entry per int16 quantized distance, index q + 32768

// Per quantized distance: log p (product form) or p (sum form), the unknown value included. Nearest lookups read
// this table instead of computing exp and log per point, on the CPU and in the shader (a texel-buffer view of the
// same values), so both backends add the same terms.
inline void likelihood_table(const EndpointModel& model, float quant_step, std::vector<float>& table) {
  const ModelConstants k(model);
  table.resize(kTableSize);
  for (int q = -32768; q <= 32767; ++q) {
    const float p = q == TsdfMap::kUnknownValue ? k.p_unknown : k.likelihood(static_cast<float>(q) * quant_step);
    table[static_cast<std::size_t>(q + 32768)] = model.likelihood == Likelihood::kProduct ? std::log(p) : p;
  }
}

// Whether two models give the same table (the exponent and interpolation are applied elsewhere).
inline bool same_table(const EndpointModel& a, const EndpointModel& b) {
  return a.sigma_hit == b.sigma_hit && a.z_hit == b.z_hit && a.z_rand == b.z_rand && a.max_range == b.max_range &&
         a.likelihood == b.likelihood && a.unknown_distance == b.unknown_distance;
}

}  // namespace tsdf_mcl::kernel
