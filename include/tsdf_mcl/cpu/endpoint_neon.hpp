#pragma once
// The nearest-lookup sensor update for 4 particles at a time with NEON (aarch64 only, where Advanced SIMD is part
// of the architecture: chosen whenever the build targets aarch64). The AVX2 path's twin: it performs exactly the
// scalar path's float operations per particle, in the same order, so its log-weights are bit-identical to the
// scalar CPU evaluator's. NEON has no gathers: the transform and the index arithmetic run in vector lanes, the
// three lookups per lane are scalar loads issued back to back, so four particles' misses overlap.
#include <cstddef>

#include "tsdf_mcl/sensor/endpoint_kernel.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl::kernel {

// True where the code was built for aarch64 (every AArch64 CPU has Advanced SIMD).
bool neon_available();

// acc[i] = Σ_j table[q(particle i, point j) + 32768] for particles [begin, end); points as x y z triples.
void accumulate_nearest_neon(const MapView& map, const float* table, const ParticleArrays& particles, std::size_t begin,
                             std::size_t end, const float* points, std::size_t point_count, float* acc);

}  // namespace tsdf_mcl::kernel
