#include "tsdf_mcl/filter/resampling.hpp"

#include <cmath>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {

double checked_sum(const double* w, std::size_t n) {
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!(w[i] >= 0.0)) throw Error("resampling: weight " + std::to_string(i) + " is negative or NaN");
    sum += w[i];
  }
  if (!(sum > 0.0) || !std::isfinite(sum)) throw Error("resampling: the weights do not sum to a positive number");
  return sum;
}

// Walks the cumulative weights weight(0..n-1) (total `sum`) with `count` pointers, writing the index under
// each; pointer(j) must be non-decreasing in j and within [0, 1).
template <typename Weight, typename Pointer>
void walk(Weight weight, std::size_t n, double sum, std::size_t count, Pointer pointer, std::uint32_t* out) {
  std::size_t i = 0;
  double cumulative = weight(0);
  for (std::size_t j = 0; j < count; ++j) {
    const double u = pointer(j) * sum;
    while (u >= cumulative && i + 1 < n) cumulative += weight(++i);
    // Rounding can leave the last pointer a hair beyond the total: the last particle with weight takes it.
    while (weight(i) == 0.0 && i > 0) --i;
    out[j] = static_cast<std::uint32_t>(i);
  }
}

// `count` independent draws: sorted uniforms as normalized partial sums of count + 1 exponentials
// (O(count), no sort). The first pass over the stream finds the total, the second replays it.
template <typename Weight>
void multinomial(Weight weight, std::size_t n, double sum, std::size_t count, Rng& rng, std::uint32_t* out) {
  Rng replay = rng;
  double total = 0.0;
  for (std::size_t j = 0; j <= count; ++j) total -= std::log(1.0 - rng.uniform());
  double partial = 0.0;
  walk(
      weight, n, sum, count,
      [&](std::size_t) {
        partial -= std::log(1.0 - replay.uniform());
        return partial / total;
      },
      out);
}

}  // namespace

ResamplingMethod parse_resampling_method(const std::string& name) {
  if (name == "systematic") return ResamplingMethod::kSystematic;
  if (name == "residual") return ResamplingMethod::kResidual;
  if (name == "multinomial") return ResamplingMethod::kMultinomial;
  throw Error("unknown resample_method '" + name + "' (systematic, residual or multinomial)");
}

std::string to_string(ResamplingMethod method) {
  switch (method) {
    case ResamplingMethod::kSystematic:
      return "systematic";
    case ResamplingMethod::kResidual:
      return "residual";
    case ResamplingMethod::kMultinomial:
      return "multinomial";
  }
  return "?";
}

void resample(ResamplingMethod method, const double* w, std::size_t n, std::size_t count, Rng& rng,
              std::uint32_t* out) {
  if (count == 0) return;
  if (n == 0) throw Error("resampling: no particles");
  const double sum = checked_sum(w, n);
  const auto weight = [w](std::size_t i) { return w[i]; };
  switch (method) {
    case ResamplingMethod::kSystematic: {
      const double offset = rng.uniform();
      const double step = 1.0 / static_cast<double>(count);
      walk(
          weight, n, sum, count, [&](std::size_t j) { return (static_cast<double>(j) + offset) * step; }, out);
      return;
    }
    case ResamplingMethod::kMultinomial:
      multinomial(weight, n, sum, count, rng, out);
      return;
    case ResamplingMethod::kResidual: {
      const double scale = static_cast<double>(count) / sum;
      std::size_t j = 0;
      double residual_sum = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        const double expected = w[i] * scale;
        const auto copies = std::min(static_cast<std::size_t>(expected), count - j);
        for (std::size_t c = 0; c < copies; ++c) out[j++] = static_cast<std::uint32_t>(i);
        residual_sum += expected - std::floor(expected);
      }
      const std::size_t rest = count - j;
      if (rest == 0) return;
      if (residual_sum > 1e-9) {
        const auto fraction = [w, scale](std::size_t i) { return w[i] * scale - std::floor(w[i] * scale); };
        multinomial(fraction, n, residual_sum, rest, rng, out + j);
      } else {
        // Only rounding left a remainder: draw it from the weights themselves.
        multinomial(weight, n, sum, rest, rng, out + j);
      }
      return;
    }
  }
}

double effective_sample_size(const double* w, std::size_t n) {
  double sum = 0.0;
  double sum2 = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    sum += w[i];
    sum2 += w[i] * w[i];
  }
  return sum2 > 0.0 ? sum * sum / sum2 : 0.0;
}

void GroupResampler::resample(ResamplingMethod method, const double* w, const std::int32_t* group, std::size_t n,
                              const std::vector<std::size_t>& counts, Rng& rng, std::uint32_t* ancestors) {
  const std::size_t groups = counts.size();
  begin_.assign(groups + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (group[i] < 0 || static_cast<std::size_t>(group[i]) >= groups)
      throw Error("resampling: bad group of particle " + std::to_string(i));
    ++begin_[static_cast<std::size_t>(group[i]) + 1];
  }
  for (std::size_t g = 0; g < groups; ++g) begin_[g + 1] += begin_[g];
  members_.resize(n);
  std::vector<std::size_t> next(begin_.begin(), begin_.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    members_[next[static_cast<std::size_t>(group[i])]++] = static_cast<std::uint32_t>(i);
  std::size_t out = 0;
  for (std::size_t g = 0; g < groups; ++g) {
    const std::size_t size = begin_[g + 1] - begin_[g];
    if (counts[g] == 0) continue;
    if (size == 0) throw Error("resampling: group " + std::to_string(g) + " has no particles to draw from");
    weights_.resize(size);
    for (std::size_t k = 0; k < size; ++k) weights_[k] = w[members_[begin_[g] + k]];
    local_.resize(counts[g]);
    tsdf_mcl::resample(method, weights_.data(), size, counts[g], rng, local_.data());
    for (std::size_t k = 0; k < counts[g]; ++k) ancestors[out++] = members_[begin_[g] + local_[k]];
  }
}

}  // namespace tsdf_mcl
