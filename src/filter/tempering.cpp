#include "tsdf_mcl/filter/tempering.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "tsdf_mcl/filter/motion_model.hpp"

namespace tsdf_mcl {
namespace {

constexpr std::size_t kChunk = 4096;      // particles per partial sum: fixed, so the sums do not depend on threads
constexpr double kMinBeta = 1e-7;         // useful values span orders of magnitude (1e-4 for 100k global particles)
constexpr double kLogTolerance = 2.5e-4;  // beta's relative precision, as 16 bisection steps over [1e-7, 1]
constexpr double kEssTolerance = 1e-3;    // or the ESS's: closer to the target than this is exact enough

struct Ess {
  double value = 0.0;
  double log_slope = 0.0;  // d ln(ESS) / d ln(beta)
};

// The ESS of exp(prior + beta * l) and its slope, the weights written to w where it is not null. One pass for the
// shift (the largest exponent: no overflow, the largest weight 1) and one for the exps and their chunked sums.
// With S1 = sum w, S2 = sum w^2: ESS = S1^2 / S2, d ln ESS / d beta = 2 sum(w l) / S1 - 2 sum(w^2 l) / S2.
Ess evaluate(const double* prior, const float* l, std::size_t n, double beta, double* w) {
  const auto count = static_cast<std::ptrdiff_t>(n);
  double max = -std::numeric_limits<double>::infinity();
#pragma omp parallel for schedule(static) reduction(max : max) if (n >= kParallelParticles)
  for (std::ptrdiff_t i = 0; i < count; ++i) max = std::max(max, prior[i] + beta * l[i]);
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::array<double, 4>> sums(chunks);
#pragma omp parallel for schedule(static) if (n >= kParallelParticles)
  for (std::ptrdiff_t c = 0; c < static_cast<std::ptrdiff_t>(chunks); ++c) {
    const std::size_t begin = static_cast<std::size_t>(c) * kChunk;
    const std::size_t end = std::min(n, begin + kChunk);
    std::array<double, 4> s{};  // sum w, sum w^2, sum w l, sum w^2 l
    for (std::size_t i = begin; i < end; ++i) {
      // Exponents below -700 are 0 to double precision beside the largest weight (1): skipping glibc exp's
      // underflow path, 3-4x slower than a normal exp, matters where most of a global belief sits.
      const double x = prior[i] + beta * l[i] - max;
      const double e = x < -700.0 ? 0.0 : std::exp(x);
      if (w) w[i] = e;
      s[0] += e;
      s[1] += e * e;
      s[2] += e * l[i];
      s[3] += e * e * l[i];
    }
    sums[static_cast<std::size_t>(c)] = s;
  }
  std::array<double, 4> s{};
  for (const std::array<double, 4>& part : sums) {
    for (int k = 0; k < 4; ++k) s[k] += part[k];
  }
  Ess ess;
  if (s[1] > 0.0) {
    ess.value = s[0] * s[0] / s[1];
    ess.log_slope = beta * (2.0 * s[2] / s[0] - 2.0 * s[3] / s[1]);
  }
  return ess;
}

}  // namespace

double tempered_ess(const double* prior, const float* l, std::size_t n, double beta) {
  return evaluate(prior, l, n, beta, nullptr).value;
}

Tempering temper(const double* prior, const float* l, std::size_t n, double target_ess, double* w) {
  Tempering t;
  Ess e = evaluate(prior, l, n, 1.0, w);
  t.ess = e.value;
  t.evaluations = 1;
  if (t.ess >= target_ess) return t;
  // The ESS falls as beta grows (the weights sharpen), smoothly in log(beta). Newton's method on
  // g(u) = ln ESS(e^u) - ln target with the analytic slope, from beta = 1, aimed inside the accepted band
  // 0 <= g <= ln(1 + kEssTolerance) and kept in the bracket [lo, hi] that holds the root: a bisection step
  // where Newton would leave it or does not shrink fast enough (as in Numerical Recipes' rtsafe). As safe as
  // bisection, and about 5 weight sets instead of its 18 (tests/filter/test_filter_tempering.cpp).
  const double log_target = std::log(target_ess);
  const double band = std::log1p(kEssTolerance);
  double lo = std::log(kMinBeta);  // ESS >= target assumed there; if not, the search ends at it
  double hi = 0.0;
  double u = hi;
  double last_step = hi - lo;
  bool accepted = false;
  while (hi - lo > kLogTolerance && t.evaluations < 100) {
    const double g = std::log(e.value) - log_target;
    const double aim = g - 0.5 * band;  // Newton aims at the band's middle
    double next = u - aim / e.log_slope;
    if (!(e.log_slope < 0.0) || !(next > lo && next < hi) || std::abs(2.0 * aim) > std::abs(last_step * e.log_slope)) {
      next = 0.5 * (lo + hi);
    }
    last_step = next - u;
    u = next;
    e = evaluate(prior, l, n, std::exp(u), w);
    ++t.evaluations;
    const double g_next = std::log(e.value) - log_target;
    if (g_next >= 0.0) {
      lo = u;
      if (g_next <= band) {
        accepted = true;
        break;
      }
    } else {
      hi = u;
    }
  }
  t.beta = std::exp(lo);
  if (accepted) {
    t.ess = e.value;  // w holds the weights at lo
  } else {
    t.ess = evaluate(prior, l, n, t.beta, w).value;
    ++t.evaluations;
  }
  return t;
}

}  // namespace tsdf_mcl
