#include "particle_order.hpp"

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "tsdf_mcl/core/morton.hpp"

namespace tsdf_mcl::bench {

void sort_spatially(const ParticleArrays& p, std::size_t n, float cell) {
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(n);
  for (std::size_t i = 0; i < n; ++i)
    keyed[i] = {morton_code(p.position(i), 1.0f / cell), static_cast<std::uint32_t>(i)};
  std::sort(keyed.begin(), keyed.end());  // the index breaks ties: a stable order
  std::vector<float> sorted(n);
  for (float* array : {p.x, p.y, p.z, p.qw, p.qx, p.qy, p.qz}) {
    for (std::size_t i = 0; i < n; ++i) sorted[i] = array[keyed[i].second];
    std::copy(sorted.begin(), sorted.end(), array);
  }
}

}  // namespace tsdf_mcl::bench
