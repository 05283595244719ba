#version 450
// Endpoint-model weighting: each particle's scan points are transformed into the map, the TSDF read there and
// the log-likelihoods (or the likelihoods, the reference implementation's summed form) accumulated.
// Two layouts, chosen by device type (EvaluatorOptions::weight_layout):
// - one invocation per particle (default build): every invocation of a workgroup reads the same point at the
//   same time. Suits lavapipe, whose SIMD lanes are the invocations of one CPU core.
// - SUBGROUP_PER_PARTICLE: one subgroup per particle, its lanes strided over the points, a subgroupAdd at the
//   end. Suits GPUs: a warp's lanes read one particle's neighbouring points, and a 1024-point scan is 32 points
//   a lane instead of 1024 dependent lookups in one thread. Mirrors tsdf_mcl/sensor/endpoint_kernel.hpp and tsdf_mcl/map/map_lookup.hpp (src/sensor, src/map) operation by operation; the transform is `precise` so no
// driver contracts it into FMAs and both sides pick the same voxel.
//
// Every invocation of a workgroup reads the same point at the same time, so point loads are broadcasts and
// no shared memory (nor barrier) is needed: lavapipe runs barrier-free shaders as plain SIMD loops.
#ifdef SUBGROUP_PER_PARTICLE
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#endif
#include "endpoint_model.glsl"
#include "map_layout.glsl"
#include "shader_interface.h"

layout(local_size_x_id = EW_SPEC_WORKGROUP) in;
layout(constant_id = EW_SPEC_INTERPOLATION) const uint INTERPOLATION = 0u;  // 0 nearest, 1 trilinear
layout(constant_id = EW_SPEC_LIKELIHOOD) const uint LIKELIHOOD = 0u;     // 0 product (log domain), 1 sum
layout(constant_id = EW_SPEC_CHUNK_SHIFT) const uint CHUNK_SHIFT = 17u;   // pool chunk = block >> CHUNK_SHIFT (maxStorageBufferRange split)
layout(constant_id = EW_SPEC_POOL_CHUNKS) const uint POOL_CHUNKS = 1u;    // chunks in use (1..4): unused reads compile away
// Points are read through a uniform-buffer view of the points buffer (EW_BINDING_UNIFORM_POINTS) when the scan fits it: every
// invocation reads the same point, which a uniform buffer serves as one broadcast load (lavapipe loops over the
// lanes for every storage-buffer load).
layout(constant_id = EW_SPEC_UNIFORM_POINTS) const uint UNIFORM_POINTS = 0u;
layout(constant_id = EW_SPEC_UNIFORM_POINT_CAPACITY) const uint UNIFORM_POINT_CAPACITY = 1u;
// The map buffers are read through uniform texel-buffer views of the same storage buffers (EW_BINDING_COARSE_VIEW onwards) when
// set: lavapipe serves a texel fetch with a SIMD gather, but every storage-buffer load with a loop over the lanes.
layout(constant_id = EW_SPEC_MAP_TEXEL_VIEWS) const uint MAP_TEXEL_VIEWS = 0u;
layout(constant_id = EW_SPEC_BATCH) const uint BATCH = 4u;  // nearest lookup: points whose map reads are issued together

// Particle structure-of-arrays: x y z qw qx qy qz log_weight, each `capacity` floats.
layout(std430, binding = EW_BINDING_PARTICLES) buffer Particles { float particle[]; };
layout(std430, binding = EW_BINDING_POINTS) readonly buffer Points { vec4 point[]; };
layout(std430, binding = EW_BINDING_COARSE) readonly buffer Coarse { uint coarse[]; };
layout(std430, binding = EW_BINDING_POOL0) readonly buffer Pool0 { uint pool0[]; };
layout(std430, binding = EW_BINDING_POOL0 + 1) readonly buffer Pool1 { uint pool1[]; };
layout(std430, binding = EW_BINDING_POOL0 + 2) readonly buffer Pool2 { uint pool2[]; };
layout(std430, binding = EW_BINDING_POOL0 + 3) readonly buffer Pool3 { uint pool3[]; };
layout(std140, binding = EW_BINDING_UNIFORM_POINTS) uniform UniformPoints { vec4 uniform_point[UNIFORM_POINT_CAPACITY]; };
layout(binding = EW_BINDING_COARSE_VIEW) uniform usamplerBuffer coarse_view;
layout(binding = EW_BINDING_POOL_VIEW0) uniform usamplerBuffer pool_view0;
layout(binding = EW_BINDING_POOL_VIEW0 + 1) uniform usamplerBuffer pool_view1;
layout(binding = EW_BINDING_POOL_VIEW0 + 2) uniform usamplerBuffer pool_view2;
layout(binding = EW_BINDING_POOL_VIEW0 + 3) uniform usamplerBuffer pool_view3;
// Nearest lookup: each quantized distance's term under the current model (float bits at q + 32768), the table
// the CPU reads too (kernel::likelihood_table). One gather replaces exp and log: 10-12 % of lavapipe's time.
layout(binding = EW_BINDING_TABLE_VIEW) uniform usamplerBuffer term_table;

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
  float p_unknown;      // a point in unknown space
  float log_p_unknown;
  float weight_exponent;
} pc;

uint pool_chunk_word(uint chunk, uint index) {
  if (MAP_TEXEL_VIEWS != 0u) {
    const int at = int(index);
    if (chunk == 0u) return texelFetch(pool_view0, at).x;
    if (POOL_CHUNKS == 2u || chunk == 1u) return texelFetch(pool_view1, at).x;
    if (POOL_CHUNKS == 3u || chunk == 2u) return texelFetch(pool_view2, at).x;
    return texelFetch(pool_view3, at).x;
  }
  if (chunk == 0u) return pool0[index];
  if (POOL_CHUNKS == 2u || chunk == 1u) return pool1[index];
  if (POOL_CHUNKS == 3u || chunk == 2u) return pool2[index];
  return pool3[index];
}

uint pool_word(uint block, uint word) {
  if (POOL_CHUNKS == 1u) return pool_chunk_word(0u, block * BLOCK_WORDS + word);
  return pool_chunk_word(block >> CHUNK_SHIFT, ((block & ((1u << CHUNK_SHIFT) - 1u)) * BLOCK_WORDS) + word);
}

uint coarse_entry(uint cell) { return MAP_TEXEL_VIEWS != 0u ? texelFetch(coarse_view, int(cell)).x : coarse[cell]; }

// Where voxel v lies: inside the map box or not, its coarse cell and its index within the block. Unsigned
// wrap-around turns "below the box" into "beyond the box", so the bounds guard is one compare per axis; outside
// voxels are clamped so that every read stays in range (the first block always exists).
void locate(ivec3 v, out bool inside, out uint cell, out uint local) {
  const uvec3 r = uvec3(v - pc.min_voxel);
  inside = all(lessThan(r, pc.dims_voxels));
  const uvec3 rc = min(r, pc.dims_voxels - 1u);
  cell = (rc.x >> 3) + pc.dims_blocks_x * ((rc.y >> 3) + pc.dims_blocks_y * (rc.z >> 3));
  local = (rc.x & 7u) + 8u * ((rc.y & 7u) + 8u * (rc.z & 7u));
}

bool allocated(bool inside, uint entry) { return inside && entry < FREE_BLOCK; }

uint voxel_word(bool inside, uint entry, uint local) {
  return pool_word(allocated(inside, entry) ? entry : 0u, local >> 1);
}

// Quantized distance, or UNKNOWN_VALUE outside the map / in unknown space: selected, never branched on.
int decode(bool inside, uint entry, uint local, uint word) {
  const int value = bitfieldExtract(int(word), int((local & 1u) << 4), 16);
  return allocated(inside, entry) ? value : ((inside && entry == FREE_BLOCK) ? QUANT_MAX : UNKNOWN_VALUE);
}

// One voxel's quantized distance. The coarse entry is cached per invocation: consecutive reads mostly fall into
// the same block, and lavapipe skips the masked-off lanes of a storage-buffer load (measured 12-20 % there).
int fetch(ivec3 v, inout uint cached_cell, inout uint cached_entry) {
  bool inside;
  uint cell, local;
  locate(v, inside, cell, local);
  if (cell != cached_cell) {
    cached_entry = coarse_entry(cell);
    cached_cell = cell;
  }
  return decode(inside, cached_entry, local, voxel_word(inside, cached_entry, local));
}

float likelihood(float d) { return endpoint_likelihood(d, pc.hit_scale, pc.neg_inv_2s2, pc.p_rand); }

// A point's term of the sum: its log-likelihood (product form) or likelihood (summed form).
float point_term(float dist) {
  const float p_point = likelihood(dist);
  return LIKELIHOOD == 0u ? log(p_point) : p_point;
}

float unknown_term() { return LIKELIHOOD == 0u ? pc.log_p_unknown : pc.p_unknown; }

float nearest_term(int q) { return uintBitsToFloat(texelFetch(term_table, q + 32768).x); }

vec3 scan_point(uint j) { return UNIFORM_POINTS != 0u ? uniform_point[j].xyz : point[j].xyz; }

vec3 to_grid(vec3 p, vec3 t, float r0, float r1, float r2, float r3, float r4, float r5, float r6, float r7, float r8) {
  return endpoint_to_grid(p, t, r0, r1, r2, r3, r4, r5, r6, r7, r8, pc.inv_voxel);
}

// One point's term at the particle's pose (rotation r0..r8, translation t), reading the map one voxel at a time
// through the invocation's coarse-entry cache.
float point_value(vec3 p, vec3 t, float r0, float r1, float r2, float r3, float r4, float r5, float r6, float r7,
                  float r8, inout uint cached_cell, inout uint cached_entry) {
  precise vec3 g = to_grid(p, t, r0, r1, r2, r3, r4, r5, r6, r7, r8);
  if (INTERPOLATION == 0u) {
    precise vec3 n = floor(g + 0.5);
    return nearest_term(fetch(ivec3(n), cached_cell, cached_entry));
  }
  precise vec3 b = floor(g);
  precise vec3 f = g - b;
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
  if (weight < 1e-3) return unknown_term();
  precise float dist = sum / weight * pc.quant_step;
  return point_term(dist);
}

void main() {
#ifdef SUBGROUP_PER_PARTICLE
  // The subgroups of a workgroup take consecutive particles; a subgroup beyond the last one leaves as a whole.
  const uint i = gl_WorkGroupID.x * gl_NumSubgroups + gl_SubgroupID;
#else
  const uint i = gl_GlobalInvocationID.x;
#endif
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
#ifdef SUBGROUP_PER_PARTICLE
  // Lane k takes points k, k + S, k + 2S, ... (S the subgroup size), read from the storage buffer (the lanes read
  // different points); the lanes' sums are added at the end, so the order of the float sums differs from the CPU's.
  for (uint j = gl_SubgroupInvocationID; j < pc.point_count; j += gl_SubgroupSize) {
    acc += point_value(point[j].xyz, t, r0, r1, r2, r3, r4, r5, r6, r7, r8, cached_cell, cached_entry);
  }
  acc = subgroupAdd(acc);
  if (subgroupElect()) particle[7u * cap + i] = pc.weight_exponent * (LIKELIHOOD == 0u ? acc : log(acc));
#else
  uint j = 0u;
  if (INTERPOLATION == 0u && BATCH > 1u) {
    // Nearest lookup, BATCH points at a time: all their coarse reads, then all their pool reads, then all their
    // table reads, then the sums (in point order, as on the CPU). Independent reads issued together overlap their
    // cache misses, which bound this loop on lavapipe; a GPU gets the same latency hiding from it.
    for (; j + BATCH <= pc.point_count; j += BATCH) {
      bool inside[BATCH];
      uint cell[BATCH], local[BATCH], entry[BATCH], word[BATCH];
      float term[BATCH];
      for (uint k = 0u; k < BATCH; ++k) {
        precise vec3 g = to_grid(scan_point(j + k), t, r0, r1, r2, r3, r4, r5, r6, r7, r8);
        precise vec3 n = floor(g + 0.5);
        locate(ivec3(n), inside[k], cell[k], local[k]);
      }
      for (uint k = 0u; k < BATCH; ++k) entry[k] = coarse_entry(cell[k]);
      for (uint k = 0u; k < BATCH; ++k) word[k] = voxel_word(inside[k], entry[k], local[k]);
      for (uint k = 0u; k < BATCH; ++k) term[k] = nearest_term(decode(inside[k], entry[k], local[k], word[k]));
      for (uint k = 0u; k < BATCH; ++k) acc += term[k];
    }
  }
  for (; j < pc.point_count; ++j) {
    acc += point_value(scan_point(j), t, r0, r1, r2, r3, r4, r5, r6, r7, r8, cached_cell, cached_entry);
  }
  particle[7u * cap + i] = pc.weight_exponent * (LIKELIHOOD == 0u ? acc : log(acc));
#endif
}
