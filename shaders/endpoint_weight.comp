#version 450
// Endpoint-model weighting: one invocation per particle transforms every scan point into the map, reads the
// TSDF there and accumulates the log-likelihood (or the summed likelihood, the reference implementation's
// form). Mirrors src/cpu/endpoint_kernel.hpp operation by operation; the transform is `precise` so no
// driver contracts it into FMAs and both sides pick the same voxel.
//
// Every invocation of a workgroup reads the same point at the same time, so point loads are broadcasts and
// no shared memory (nor barrier) is needed: lavapipe runs barrier-free shaders as plain SIMD loops.
#include "map_layout.glsl"

layout(local_size_x_id = 0) in;
layout(constant_id = 1) const uint INTERPOLATION = 0u;  // 0 nearest, 1 trilinear
layout(constant_id = 2) const uint LIKELIHOOD = 0u;     // 0 product (log domain), 1 sum
layout(constant_id = 3) const uint CHUNK_SHIFT = 17u;   // pool chunk = block >> CHUNK_SHIFT (maxStorageBufferRange split)
layout(constant_id = 4) const uint POOL_CHUNKS = 1u;    // chunks in use (1..4): unused reads compile away
// Points are read through a uniform-buffer view of the points buffer (binding 7) when the scan fits it: every
// invocation reads the same point, which a uniform buffer serves as one broadcast load (lavapipe loops over the
// lanes for every storage-buffer load).
layout(constant_id = 5) const uint UNIFORM_POINTS = 0u;
layout(constant_id = 6) const uint UNIFORM_POINT_CAPACITY = 1u;

// Particle structure-of-arrays: x y z qw qx qy qz log_weight, each `capacity` floats.
layout(std430, binding = 0) buffer Particles { float particle[]; };
layout(std430, binding = 1) readonly buffer Points { vec4 point[]; };
layout(std430, binding = 2) readonly buffer Coarse { uint coarse[]; };
layout(std430, binding = 3) readonly buffer Pool0 { uint pool0[]; };
layout(std430, binding = 4) readonly buffer Pool1 { uint pool1[]; };
layout(std430, binding = 5) readonly buffer Pool2 { uint pool2[]; };
layout(std430, binding = 6) readonly buffer Pool3 { uint pool3[]; };
layout(std140, binding = 7) uniform UniformPoints { vec4 uniform_point[UNIFORM_POINT_CAPACITY]; };

// Mirrored by gpu::EndpointPushConstants (src/gpu/push_constants.hpp).
layout(push_constant) uniform Params {
  uint particle_count;
  uint point_count;
  uint capacity;
  float inv_voxel;
  ivec3 min_voxel;
  float quant_step;
  uvec3 dims_voxels;
  uint dims_blocks_x;
  uint dims_blocks_y;
  float hit_scale;    // z_hit / (sigma sqrt(2 pi))
  float neg_inv_2s2;  // -1 / (2 sigma^2)
  float p_rand;
  float log_p_rand;
  float weight_exponent;
} pc;

uint pool_word(uint block, uint word) {
  if (POOL_CHUNKS == 1u) return pool0[block * BLOCK_WORDS + word];
  const uint chunk = block >> CHUNK_SHIFT;
  const uint index = ((block & ((1u << CHUNK_SHIFT) - 1u)) * BLOCK_WORDS) + word;
  if (chunk == 0u) return pool0[index];
  if (POOL_CHUNKS == 2u || chunk == 1u) return pool1[index];
  if (POOL_CHUNKS == 3u || chunk == 2u) return pool2[index];
  return pool3[index];
}

// Quantized distance of voxel v, or UNKNOWN_VALUE outside the map / in unknown space. The pool read always
// happens (clamped in range: the first block always exists) and the result is selected. The coarse entry is
// cached per invocation: consecutive scan points mostly fall into the same block, and a skipped load is a real
// saving on lavapipe, where each storage-buffer load is a loop over the lanes (measured 12-20 % there).
int fetch(ivec3 v, inout uint cached_cell, inout uint cached_entry) {
  // Unsigned wrap-around turns "below the box" into "beyond the box": the bounds guard is one compare per axis.
  const uvec3 r = uvec3(v - pc.min_voxel);
  const bool inside = all(lessThan(r, pc.dims_voxels));
  const uvec3 rc = min(r, pc.dims_voxels - 1u);
  const uint cell = (rc.x >> 3) + pc.dims_blocks_x * ((rc.y >> 3) + pc.dims_blocks_y * (rc.z >> 3));
  if (cell != cached_cell) {
    cached_entry = coarse[cell];
    cached_cell = cell;
  }
  const uint entry = cached_entry;
  const bool allocated = inside && entry < FREE_BLOCK;
  const uint l = (rc.x & 7u) + 8u * ((rc.y & 7u) + 8u * (rc.z & 7u));
  const uint word = pool_word(allocated ? entry : 0u, l >> 1);
  const int value = bitfieldExtract(int(word), int((l & 1u) << 4), 16);
  return allocated ? value : ((inside && entry == FREE_BLOCK) ? QUANT_MAX : UNKNOWN_VALUE);
}

float likelihood(float d) { return pc.hit_scale * exp(d * d * pc.neg_inv_2s2) + pc.p_rand; }

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= pc.particle_count) return;
  const uint cap = pc.capacity;
  const vec3 t = vec3(particle[i], particle[cap + i], particle[2u * cap + i]);
  const float qw = particle[3u * cap + i];
  const float qx = particle[4u * cap + i];
  const float qy = particle[5u * cap + i];
  const float qz = particle[6u * cap + i];

  precise float xx = qx * qx, yy = qy * qy, zz = qz * qz;
  precise float xy = qx * qy, xz = qx * qz, yz = qy * qz;
  precise float wx = qw * qx, wy = qw * qy, wz = qw * qz;
  precise float r0 = 1.0 - 2.0 * (yy + zz), r1 = 2.0 * (xy - wz), r2 = 2.0 * (xz + wy);
  precise float r3 = 2.0 * (xy + wz), r4 = 1.0 - 2.0 * (xx + zz), r5 = 2.0 * (yz - wx);
  precise float r6 = 2.0 * (xz - wy), r7 = 2.0 * (yz + wx), r8 = 1.0 - 2.0 * (xx + yy);

  float acc = 0.0;
  uint cached_cell = 0xFFFFFFFFu;
  uint cached_entry = 0u;
  for (uint j = 0u; j < pc.point_count; ++j) {
    const vec3 p = UNIFORM_POINTS != 0u ? uniform_point[j].xyz : point[j].xyz;
    precise float gx = (r0 * p.x + r1 * p.y + r2 * p.z + t.x) * pc.inv_voxel;
    precise float gy = (r3 * p.x + r4 * p.y + r5 * p.z + t.y) * pc.inv_voxel;
    precise float gz = (r6 * p.x + r7 * p.y + r8 * p.z + t.z) * pc.inv_voxel;
    float v;
    if (INTERPOLATION == 0u) {
      precise vec3 n = floor(vec3(gx, gy, gz) + 0.5);
      const int q = fetch(ivec3(n), cached_cell, cached_entry);
      if (q == UNKNOWN_VALUE) {
        v = LIKELIHOOD == 0u ? pc.log_p_rand : pc.p_rand;
      } else {
        const float p_point = likelihood(float(q) * pc.quant_step);
        v = LIKELIHOOD == 0u ? log(p_point) : p_point;
      }
    } else {
      precise vec3 b = floor(vec3(gx, gy, gz));
      precise vec3 f = vec3(gx, gy, gz) - b;
      const ivec3 base = ivec3(b);
      precise float weight = 0.0;
      precise float sum = 0.0;
      for (int corner = 0; corner < 8; ++corner) {
        const ivec3 d = ivec3(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        const int q = fetch(base + d, cached_cell, cached_entry);
        if (q == UNKNOWN_VALUE) continue;
        precise float w = (d.x != 0 ? f.x : 1.0 - f.x) * (d.y != 0 ? f.y : 1.0 - f.y) * (d.z != 0 ? f.z : 1.0 - f.z);
        weight += w;
        sum += w * float(q);
      }
      if (weight < 1e-3) {
        v = LIKELIHOOD == 0u ? pc.log_p_rand : pc.p_rand;
      } else {
        precise float dist = sum / weight * pc.quant_step;
        const float p_point = likelihood(dist);
        v = LIKELIHOOD == 0u ? log(p_point) : p_point;
      }
    }
    acc += v;
  }
  particle[7u * cap + i] = pc.weight_exponent * (LIKELIHOOD == 0u ? acc : log(acc));
}
