#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "tsdf_mcl/filter/tempering.hpp"

namespace tsdf_mcl {
namespace {

// Log-likelihoods of a belief: most particles far off (spread `spread` per scan), a few near the truth.
struct Belief {
  std::vector<double> prior;
  std::vector<float> l;
};

Belief make_belief(std::size_t n, double spread, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Belief b;
  b.prior.resize(n);
  b.l.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    b.prior[i] = 0.1 * normal(rng);
    b.l[i] = static_cast<float>(-spread * std::abs(normal(rng)) + (i % 997 == 0 ? 0.5 * spread : 0.0));
  }
  return b;
}

// The root by 40 bisection steps in log(beta): the reference temper() approximates with fewer weight sets.
double reference_beta(const Belief& b, double target) {
  double lo = std::log(1e-7);
  double hi = 0.0;
  for (int i = 0; i < 40; ++i) {
    const double mid = 0.5 * (lo + hi);
    (tempered_ess(b.prior.data(), b.l.data(), b.l.size(), std::exp(mid)) >= target ? lo : hi) = mid;
  }
  return std::exp(lo);
}

TEST(Tempering, KeepsBetaOneWhereTheWeightsLeaveEnoughSamples) {
  const Belief b = make_belief(1000, 0.01, 1);
  std::vector<double> w(b.l.size());
  const Tempering t = temper(b.prior.data(), b.l.data(), b.l.size(), 100.0, w.data());
  EXPECT_EQ(t.beta, 1.0);
  EXPECT_EQ(t.evaluations, 1);
  double max = -1e300;
  for (std::size_t i = 0; i < w.size(); ++i) max = std::max(max, b.prior[i] + b.l[i]);
  for (std::size_t i = 0; i < w.size(); ++i) EXPECT_NEAR(w[i], std::exp(b.prior[i] + b.l[i] - max), 1e-15);
}

TEST(Tempering, FindsTheLargestBetaThatKeepsTheTargetInFewWeightSets) {
  // Spreads from a converged track's (a few per scan) to a global belief's (hundreds), sizes up to 100k.
  for (const std::size_t n : {2000u, 30000u, 100000u}) {
    for (const double spread : {20.0, 100.0, 1000.0, 10000.0}) {
      const Belief b = make_belief(n, spread, static_cast<unsigned>(n + spread));
      const double target = 0.1 * static_cast<double>(n);
      std::vector<double> w(n);
      const Tempering t = temper(b.prior.data(), b.l.data(), n, target, w.data());
      SCOPED_TRACE(testing::Message() << "n " << n << " spread " << spread);
      ASSERT_LT(t.beta, 1.0);
      EXPECT_GE(t.ess, target);  // never fewer samples than asked for
      const double reference = reference_beta(b, target);
      // As close as the old 16-step bisection came (2.5e-4 in log beta), or the ESS within 0.1 % of the target.
      EXPECT_TRUE(std::abs(std::log(t.beta / reference)) <= 2.5e-4 || t.ess <= 1.001 * target)
          << "beta " << t.beta << " reference " << reference << " ess " << t.ess;
      EXPECT_LE(t.beta, reference * (1.0 + 1e-12));
      std::printf("n %zu spread %g: %d weight sets\n", n, spread, t.evaluations);
      EXPECT_LE(t.evaluations, 12) << "the point of false position: fewer weight sets than bisection's 18";
      // The weights written are the ones at beta.
      EXPECT_NEAR(tempered_ess(b.prior.data(), b.l.data(), n, t.beta), t.ess, 1e-9 * t.ess);
    }
  }
}

TEST(Tempering, FallsBackToTheSmallestBetaWhenEvenThatIsTooSharp) {
  Belief b;
  b.prior.assign(100, 0.0);
  b.l.assign(100, 0.0f);
  b.l[7] = 1e9f;  // one particle explains the scan a billion times better than the rest
  std::vector<double> w(100);
  const Tempering t = temper(b.prior.data(), b.l.data(), 100, 50.0, w.data());
  EXPECT_DOUBLE_EQ(t.beta, 1e-7);
  EXPECT_EQ(w[7], 1.0);
  EXPECT_LT(t.ess, 50.0);
}

TEST(Tempering, DoesNotDependOnTheThreadCount) {
  const Belief b = make_belief(50000, 300.0, 5);
  std::vector<double> w1(50000), w4(50000);
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const Tempering t1 = temper(b.prior.data(), b.l.data(), 50000, 5000.0, w1.data());
  omp_set_num_threads(4);
  const Tempering t4 = temper(b.prior.data(), b.l.data(), 50000, 5000.0, w4.data());
  omp_set_num_threads(threads);
  EXPECT_EQ(t1.beta, t4.beta);
  EXPECT_EQ(t1.ess, t4.ess);
  EXPECT_EQ(w1, w4);
}

}  // namespace
}  // namespace tsdf_mcl
