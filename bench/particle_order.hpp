#pragma once
// Particles in spatial order (bench --order spatial): sorted by the Morton (Z-order) code of their position, so
// that the particles one SIMD group or workgroup evaluates together, and those that follow, read nearby parts of
// the map. On particles drawn uniformly over the map box in random order it saves about a fifth of a sensor update
// on both backends; in the filter's global phase (the best 100k of a million screened hypotheses, clustered on the
// places that fit) it measured no gain, so the filter does not sort (docs/sensor-update.md, "What did not pay").
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl::bench {

// Permutes particles 0..n-1 of p (positions and rotations) into Morton order of cells of `cell` metres; equal
// cells keep their particles' relative order.
void sort_spatially(const ParticleArrays& p, std::size_t n, float cell = 0.4f);

}  // namespace tsdf_mcl::bench
