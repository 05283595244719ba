#pragma once
// Resampling on the host: which particles of the weighted set the next generation copies.
#include <cstddef>
#include <cstdint>
#include <string>

#include "tsdf_mcl/random.hpp"

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

// (Σw)² / Σw²: how many equally weighted particles the weighted set is worth.
double effective_sample_size(const double* weights, std::size_t n);

}  // namespace tsdf_mcl
