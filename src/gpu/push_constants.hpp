#pragma once
// C++ mirrors of the shaders' push-constant blocks (the `Params` blocks of shaders/endpoint_weight.comp and
// shaders/reduce.comp), in GLM's GLSL types. A GLSL ivec3/uvec3/vec4 member starts on a 16-byte boundary in a
// push-constant block; GLM's types do not, so those members carry alignas(16), and the offsets are checked here.
#include <cstddef>
#include <cstdint>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "shader_interface.h"

namespace tsdf_mcl::gpu {

struct EndpointPushConstants {
  std::uint32_t particle_count;
  std::uint32_t point_count;
  std::uint32_t capacity;
  float inv_voxel;
  alignas(16) glm::ivec3 min_voxel;
  float quant_step;
  alignas(16) glm::uvec3 dims_voxels;
  std::uint32_t dims_blocks_x;
  std::uint32_t dims_blocks_y;
  float hit_scale;
  float neg_inv_2s2;
  float p_rand;
  float p_unknown;
  float log_p_unknown;
  float weight_exponent;
};
static_assert(offsetof(EndpointPushConstants, min_voxel) == 16 && offsetof(EndpointPushConstants, quant_step) == 28 &&
                  offsetof(EndpointPushConstants, dims_voxels) == 32 &&
                  offsetof(EndpointPushConstants, dims_blocks_x) == 44 &&
                  offsetof(EndpointPushConstants, weight_exponent) == 72,
              "std430 offsets of endpoint_weight.comp's Params");

struct ReducePushConstants {
  std::uint32_t count;
  std::uint32_t capacity;
  std::uint32_t level;
  float fit_scale;
  alignas(16) glm::vec4 reference;  // w x y z
  float fit_offset;
};
static_assert(offsetof(ReducePushConstants, reference) == 16 && offsetof(ReducePushConstants, fit_offset) == 32,
              "std430 offsets of reduce.comp's Params");

constexpr std::uint32_t kReduceRecordFloats = RD_RECORD_FLOATS;

}  // namespace tsdf_mcl::gpu
