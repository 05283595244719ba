#pragma once
// The nearest-lookup sensor update for 8 particles at a time with AVX2 gathers (x86-64 only, chosen at run
// time). It performs exactly the scalar path's float operations per particle, in the same order, so its
// log-weights are bit-identical to the scalar CPU evaluator's. Batches of points go through short loops of
// independent gathers, so that many lookups are in flight at once: what a memory-bound loop needs.
#include <cstddef>

#include "tsdf_mcl/sensor/endpoint_kernel.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl::kernel {

// True where the CPU has AVX2 and the code was built for x86-64.
bool avx2_available();

// acc[i] = Σ_j table[q(particle i, point j) + 32768] for particles [begin, end); points as x y z triples.
void accumulate_nearest_avx2(const MapView& map, const float* table, const ParticleArrays& particles, std::size_t begin,
                             std::size_t end, const float* points, std::size_t point_count, float* acc);

}  // namespace tsdf_mcl::kernel
