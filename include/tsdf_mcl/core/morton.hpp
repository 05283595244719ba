#pragma once
// Morton (Z-order) codes of 3-D points: cells close in space get close codes, so sorting by the code orders points
// or particles along a space-filling curve (scan preprocessing, bench --order spatial).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>

namespace tsdf_mcl {

// Spreads the low 21 bits of v so that two zero bits follow each one.
inline std::uint64_t morton_spread_bits(std::uint64_t v) {
  v &= 0x1FFFFFull;
  v = (v | (v << 32)) & 0x1F00000000FFFFull;
  v = (v | (v << 16)) & 0x1F0000FF0000FFull;
  v = (v | (v << 8)) & 0x100F00F00F00F00Full;
  v = (v | (v << 4)) & 0x10C30C30C30C30C3ull;
  v = (v | (v << 2)) & 0x1249249249249249ull;
  return v;
}

// The code of the cell (size 1 / inv_cell) holding p: cells -2^20 .. 2^20-1 per axis (±100 km at 0.1 m), beyond
// them clamped.
inline std::uint64_t morton_code(const Eigen::Vector3f& p, float inv_cell) {
  constexpr std::int64_t kOffset = 1 << 20;
  std::uint64_t key = 0;
  for (int a = 0; a < 3; ++a) {
    const float scaled = std::clamp(p[a] * inv_cell, -2.0e6f, 2.0e6f);  // the cast stays in range
    const auto cell = static_cast<std::int64_t>(std::floor(scaled)) + kOffset;
    key |= morton_spread_bits(static_cast<std::uint64_t>(std::clamp<std::int64_t>(cell, 0, 2 * kOffset - 1))) << a;
  }
  return key;
}

}  // namespace tsdf_mcl
