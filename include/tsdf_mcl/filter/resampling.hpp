#pragma once
// Resampling on the host: which particles of the weighted set the next generation copies.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "tsdf_mcl/core/random.hpp"

namespace tsdf_mcl {

enum class ResamplingMethod {
  // Low-variance (systematic): one uniform offset, `count` equally spaced pointers into the cumulative weights.
  // Particle i gets floor(count * w_i / W) or that plus one copies: the least added variance, O(n + count).
  kSystematic,
  // floor(count * w_i / W) copies deterministically, the rest drawn multinomially from the fractional parts.
  kResidual,
  // `count` independent draws from the weights (the textbook version; most variance).
  kMultinomial,
};
ResamplingMethod parse_resampling_method(const std::string& name);  // "systematic" | "residual" | "multinomial"
std::string to_string(ResamplingMethod method);

// Writes `count` ancestor indices into ancestors[0..count) (ascending for systematic and multinomial; residual
// lists its deterministic copies first), drawn from the non-negative
// weights w[0..n) (any positive scale). Throws Error if the weights do not sum to a positive finite value.
void resample(ResamplingMethod method, const double* weights, std::size_t n, std::size_t count, Rng& rng,
              std::uint32_t* ancestors);

// Resampling group by group (one group per place, so a place keeps the particle count it was given
// whatever its weight): counts[g] ancestors drawn from group g's particles by their weights, written group after
// group (group 0's first). group[i] in [0, counts.size()); a group whose weights sum to zero must get count 0.
// Keeps its buffers between calls.
class GroupResampler {
 public:
  void resample(ResamplingMethod method, const double* weights, const std::int32_t* group, std::size_t n,
                const std::vector<std::size_t>& counts, Rng& rng, std::uint32_t* ancestors);

 private:
  std::vector<std::uint32_t> members_;  // particle indices sorted by group
  std::vector<std::size_t> begin_;      // members_ of group g: [begin_[g], begin_[g + 1])
  std::vector<double> weights_;         // the group's weights, contiguous
  std::vector<std::uint32_t> local_;    // ancestors within the group
};

// (Σw)² / Σw²: how many equally weighted particles the weighted set is worth.
double effective_sample_size(const double* weights, std::size_t n);

}  // namespace tsdf_mcl
