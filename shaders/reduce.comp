#version 450
// Tree reduction over particles of (max log-weight, Σw, Σw·position, Σw·quaternion, Σfit), w = exp(l - max).
// Records combine like an online softmax (sums relative to their own maximum), so one pass over the data
// suffices and nothing overflows. Level 0 reads the particles, later levels the previous level's records;
// each workgroup writes one record. Mirrors src/sensor/weight_reduction.cpp.
//
// Variants: USE_SUBGROUP_ARITHMETIC reduces inside subgroups first (any subgroup size: lavapipe 8, NVIDIA 32,
// AMD 64); without it a plain shared-memory tree. Both keep every barrier in uniform control flow.
#ifdef USE_SUBGROUP_ARITHMETIC
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#endif
#include "shader_interface.h"

layout(local_size_x_id = RD_SPEC_WORKGROUP) in;  // a power of two
layout(constant_id = RD_SPEC_ITEMS_PER_THREAD) const uint ITEMS_PER_THREAD = 4u;

const uint RECORD = RD_RECORD_FLOATS;
const float EMPTY = -3.0e38;

layout(std430, binding = RD_BINDING_PARTICLES) readonly buffer Particles { float particle[]; };
layout(std430, binding = RD_BINDING_RECORDS_IN) readonly buffer RecordsIn { float record_in[]; };
layout(std430, binding = RD_BINDING_RECORDS_OUT) writeonly buffer RecordsOut { float record_out[]; };

// Mirrored by gpu::ReducePushConstants (src/gpu/push_constants.hpp).
layout(push_constant) uniform Params {
  uint count;      // elements at this level
  uint capacity;   // particle array stride (level 0)
  uint level;      // 0: read particles, else records
  float fit_scale; // fit_i = exp(l * fit_scale + fit_offset)
  vec4 reference;  // reference quaternion (w, x, y, z) for sign alignment
  float fit_offset;
} pc;

struct Rec {
  float m;
  float s;
  vec3 p;
  vec4 q;
  float fit;
};

Rec empty_rec() { return Rec(EMPTY, 0.0, vec3(0.0), vec4(0.0), 0.0); }

Rec combine(Rec a, Rec b) {
  if (b.s == 0.0) { a.fit += b.fit; return a; }
  if (a.s == 0.0) { b.fit += a.fit; return b; }
  const float m = max(a.m, b.m);
  const float sa = exp(a.m - m);
  const float sb = exp(b.m - m);
  return Rec(m, a.s * sa + b.s * sb, a.p * sa + b.p * sb, a.q * sa + b.q * sb, a.fit + b.fit);
}

Rec load(uint k) {
  if (pc.level == 0u) {
    const uint cap = pc.capacity;
    const float l = particle[7u * cap + k];
    vec4 q = vec4(particle[3u * cap + k], particle[4u * cap + k], particle[5u * cap + k], particle[6u * cap + k]);
    if (dot(q, pc.reference) < 0.0) q = -q;
    const vec3 p = vec3(particle[k], particle[cap + k], particle[2u * cap + k]);
    return Rec(l, 1.0, p, q, exp(l * pc.fit_scale + pc.fit_offset));
  }
  const uint b = k * RECORD;
  return Rec(record_in[b], record_in[b + 1u], vec3(record_in[b + 2u], record_in[b + 3u], record_in[b + 4u]),
             vec4(record_in[b + 5u], record_in[b + 6u], record_in[b + 7u], record_in[b + 8u]), record_in[b + 9u]);
}

#ifdef USE_SUBGROUP_ARITHMETIC
shared Rec partial[gl_WorkGroupSize.x];  // one slot per subgroup is used; sized for subgroups of 1

Rec subgroup_combine(Rec r) {
  const float m = subgroupMax(r.m);
  const float scale = r.s > 0.0 ? exp(r.m - m) : 0.0;
  return Rec(m, subgroupAdd(r.s * scale), subgroupAdd(r.p * scale), subgroupAdd(r.q * scale), subgroupAdd(r.fit));
}
#else
shared Rec partial[gl_WorkGroupSize.x];
#endif

void main() {
  const uint tid = gl_LocalInvocationID.x;
  const uint group_first = gl_WorkGroupID.x * gl_WorkGroupSize.x * ITEMS_PER_THREAD;
  // Strided so that neighbouring invocations read neighbouring elements.
  Rec acc = empty_rec();
  for (uint k = 0u; k < ITEMS_PER_THREAD; ++k) {
    const uint e = group_first + k * gl_WorkGroupSize.x + tid;
    if (e < pc.count) acc = combine(acc, load(e));
  }

#ifdef USE_SUBGROUP_ARITHMETIC
  // One subgroup round, then a shared-memory tree over the per-subgroup records: no assumption about which
  // invocations form a subgroup, only that each subgroup writes its own slot.
  const Rec r = subgroup_combine(acc);
  if (subgroupElect()) partial[gl_SubgroupID] = r;
  barrier();
  uint width = 1u;
  while (width < gl_NumSubgroups) width <<= 1u;
  for (uint stride = width >> 1u; stride > 0u; stride >>= 1u) {
    if (tid < stride && tid + stride < gl_NumSubgroups) partial[tid] = combine(partial[tid], partial[tid + stride]);
    barrier();
  }
  if (tid == 0u) acc = partial[0];
#else
  partial[tid] = acc;
  barrier();
  for (uint stride = gl_WorkGroupSize.x / 2u; stride > 0u; stride >>= 1u) {
    if (tid < stride) partial[tid] = combine(partial[tid], partial[tid + stride]);
    barrier();
  }
  if (tid == 0u) acc = partial[0];
#endif

  if (tid == 0u) {
    const uint b = gl_WorkGroupID.x * RECORD;
    record_out[b] = acc.m;
    record_out[b + 1u] = acc.s;
    record_out[b + 2u] = acc.p.x;
    record_out[b + 3u] = acc.p.y;
    record_out[b + 4u] = acc.p.z;
    record_out[b + 5u] = acc.q.x;
    record_out[b + 6u] = acc.q.y;
    record_out[b + 7u] = acc.q.z;
    record_out[b + 8u] = acc.q.w;
    record_out[b + 9u] = acc.fit;
    record_out[b + 10u] = 0.0;
    record_out[b + 11u] = 0.0;
  }
}
