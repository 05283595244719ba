// The endpoint model's per-point arithmetic in GLSL: the mirror of tsdf_mcl/sensor/endpoint_kernel.hpp (to_grid,
// ModelConstants::likelihood), operation by operation. Included by shaders/endpoint_weight.comp; the
// tests compare the two on lavapipe (VulkanVsCpu).
#ifndef ENDPOINT_MODEL_GLSL
#define ENDPOINT_MODEL_GLSL

// hit_scale exp(d^2 neg_inv_2s2) + p_rand: the mixture of the hit Gaussian and the uniform part.
float endpoint_likelihood(float d, float hit_scale, float neg_inv_2s2, float p_rand) {
  return hit_scale * exp(d * d * neg_inv_2s2) + p_rand;
}

// Point p (sensor frame) in grid units of the map, under the rotation r0..r8 (row-major) and the translation t.
// Every operation is `precise` (no FMA contraction) so that the CPU picks the same voxel.
vec3 endpoint_to_grid(vec3 p, vec3 t, float r0, float r1, float r2, float r3, float r4, float r5, float r6, float r7,
                      float r8, float inv_voxel) {
  precise float gx = (r0 * p.x + r1 * p.y + r2 * p.z + t.x) * inv_voxel;
  precise float gy = (r3 * p.x + r4 * p.y + r5 * p.z + t.y) * inv_voxel;
  precise float gz = (r6 * p.x + r7 * p.y + r8 * p.z + t.z) * inv_voxel;
  return vec3(gx, gy, gz);
}

#endif
