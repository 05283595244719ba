#pragma once
// Arithmetic on values that come from files: a size product or sum that would wrap is an error, not a small number;
// a float position becomes an integer index only through a saturating conversion (converting a float beyond int's
// range is undefined behaviour).
#include <cmath>
#include <cstdint>
#include <string>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::io {

inline std::uint64_t checked_mul(std::uint64_t a, std::uint64_t b, const std::string& what) {
  std::uint64_t product = 0;
  if (__builtin_mul_overflow(a, b, &product)) throw Error(what + ": size overflows 64 bits (corrupt size field)");
  return product;
}

inline std::uint64_t checked_add(std::uint64_t a, std::uint64_t b, const std::string& what) {
  std::uint64_t sum = 0;
  if (__builtin_add_overflow(a, b, &sum)) throw Error(what + ": size overflows 64 bits (corrupt size field)");
  return sum;
}

// floor(v) / ceil(v) as int, saturated at +-2^30 (NaN gives -2^30): far outside any map (limits::kMaxAbsVoxelIndex)
// or image, yet with room for the +-1 neighbours of index arithmetic.
inline int saturated_floor(double v) {
  constexpr double kFar = 1 << 30;
  if (!(v > -kFar)) return -(1 << 30);
  if (v > kFar) return 1 << 30;
  return static_cast<int>(std::floor(v));
}
inline int saturated_ceil(double v) { return -saturated_floor(-v); }

}  // namespace tsdf_mcl::io
