#pragma once
// C++ mirrors of the shaders' push-constant blocks (std430-compatible scalar layouts); keep in sync with the
// `Params` blocks of shaders/endpoint_weight.comp and shaders/reduce.comp.
#include <cstddef>
#include <cstdint>

namespace tsdf_mcl::gpu {

struct EndpointPushConstants {
  std::uint32_t particle_count;
  std::uint32_t point_count;
  std::uint32_t capacity;
  float inv_voxel;
  std::int32_t min_voxel[3];
  float quant_step;
  std::uint32_t dims_voxels[3];
  std::uint32_t dims_blocks_x;
  std::uint32_t dims_blocks_y;
  float hit_scale;
  float neg_inv_2s2;
  float p_rand;
  float log_p_rand;
  float weight_exponent;
};
static_assert(sizeof(EndpointPushConstants) == 72, "must match endpoint_weight.comp");
static_assert(offsetof(EndpointPushConstants, min_voxel) == 16 && offsetof(EndpointPushConstants, dims_voxels) == 32,
              "ivec3/uvec3 start on 16-byte boundaries in the shader");

struct ReducePushConstants {
  std::uint32_t count;
  std::uint32_t capacity;
  std::uint32_t level;
  float fit_scale;
  float reference[4];  // w x y z
  float fit_offset;
};
static_assert(sizeof(ReducePushConstants) == 36, "must match reduce.comp");
static_assert(offsetof(ReducePushConstants, reference) == 16, "vec4 starts on a 16-byte boundary in the shader");

constexpr std::uint32_t kReduceRecordFloats = 12;

}  // namespace tsdf_mcl::gpu
