#pragma once
// Random numbers that are the same on every platform and standard library: the std:: distributions are
// implementation-defined, so a seed would not reproduce a scene or a dataset elsewhere.
#include <cstdint>

#include "tsdf_mcl/core/random.hpp"

namespace tsdf_mcl::sim {

// The filter's generator (xoshiro256**, seeded through SplitMix64), shared so the project has one.
using tsdf_mcl::Rng;

constexpr std::uint64_t splitmix64(std::uint64_t x) { return mix64(x); }

// Derives independent streams from one seed (a stream per purpose, per scan, per ray).
constexpr std::uint64_t mix_key(std::uint64_t a, std::uint64_t b) { return mix64(a ^ mix64(b)); }

inline double unit_double(std::uint64_t bits) { return static_cast<double>(bits >> 11) * 0x1.0p-53; }

}  // namespace tsdf_mcl::sim
