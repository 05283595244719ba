#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/resampling.hpp"

namespace tsdf_mcl {
namespace {

std::vector<std::size_t> copies(const std::vector<std::uint32_t>& ancestors, std::size_t n) {
  std::vector<std::size_t> c(n, 0);
  for (std::uint32_t a : ancestors) ++c.at(a);
  return c;
}

std::vector<double> random_weights(std::size_t n, Rng& rng) {
  std::vector<double> w(n);
  for (auto& v : w) v = rng.uniform() < 0.2 ? 0.0 : std::exp(3.0 * rng.normal());  // skewed, some zero
  return w;
}

// Low-variance resampling gives every particle floor(N w_i / W) or one more copy.
TEST(Resampling, SystematicGivesFloorOrCeilOfExpectedCopies) {
  for (std::uint64_t seed = 0; seed < 50; ++seed) {
    Rng rng(seed);
    const std::size_t n = 1 + rng.below(300);
    const std::size_t count = 1 + rng.below(2000);
    const std::vector<double> w = random_weights(n, rng);
    if (std::all_of(w.begin(), w.end(), [](double v) { return v == 0.0; })) continue;
    double sum = 0.0;
    for (double v : w) sum += v;
    std::vector<std::uint32_t> ancestors(count);
    resample(ResamplingMethod::kSystematic, w.data(), n, count, rng, ancestors.data());
    EXPECT_TRUE(std::is_sorted(ancestors.begin(), ancestors.end()));
    const auto c = copies(ancestors, n);
    for (std::size_t i = 0; i < n; ++i) {
      const double expected = static_cast<double>(count) * w[i] / sum;
      ASSERT_GE(static_cast<double>(c[i]), std::floor(expected - 1e-9)) << "seed " << seed << " particle " << i;
      ASSERT_LE(static_cast<double>(c[i]), std::ceil(expected + 1e-9)) << "seed " << seed << " particle " << i;
      if (w[i] == 0.0) {
        ASSERT_EQ(c[i], 0u);
      }
    }
  }
}

// The low-variance draw is unbiased: its one offset is random, so that a particle expected 0.3 copies gets one in
// three draws out of ten, not never (an offset fixed at 0.5) or always (at 0). Over 4,000 draws the mean copies of
// each particle match N w_i / W to within five standard errors.
TEST(Resampling, SystematicIsUnbiasedOverDraws) {
  const std::vector<double> w = {0.3, 1.7, 0.45, 2.55, 0.05, 4.95};  // expected copies with count 10: 0.3 ... 4.95
  const std::size_t count = 10, draws = 4000;
  double sum = 0.0;
  for (double v : w) sum += v;
  std::vector<double> mean(w.size(), 0.0);
  Rng rng(7);
  std::vector<std::uint32_t> ancestors(count);
  for (std::size_t d = 0; d < draws; ++d) {
    resample(ResamplingMethod::kSystematic, w.data(), w.size(), count, rng, ancestors.data());
    const auto c = copies(ancestors, w.size());
    for (std::size_t i = 0; i < w.size(); ++i) mean[i] += static_cast<double>(c[i]) / static_cast<double>(draws);
  }
  for (std::size_t i = 0; i < w.size(); ++i) {
    const double expected = static_cast<double>(count) * w[i] / sum;
    const double frac = expected - std::floor(expected);
    const double standard_error = std::sqrt(frac * (1.0 - frac) / static_cast<double>(draws));
    EXPECT_NEAR(mean[i], expected, 5.0 * standard_error + 1e-9) << "particle " << i;
  }
}

TEST(Resampling, ResidualGivesAtLeastTheIntegerPartOfExpectedCopies) {
  for (std::uint64_t seed = 0; seed < 50; ++seed) {
    Rng rng(seed + 1000);
    const std::size_t n = 1 + rng.below(200);
    const std::size_t count = 1 + rng.below(1000);
    const std::vector<double> w = random_weights(n, rng);
    if (std::all_of(w.begin(), w.end(), [](double v) { return v == 0.0; })) continue;
    double sum = 0.0;
    for (double v : w) sum += v;
    std::vector<std::uint32_t> ancestors(count, 0xFFFFFFFFu);
    resample(ResamplingMethod::kResidual, w.data(), n, count, rng, ancestors.data());
    const auto c = copies(ancestors, n);
    std::size_t total = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double expected = static_cast<double>(count) * w[i] / sum;
      ASSERT_GE(static_cast<double>(c[i]), std::floor(expected - 1e-9)) << "seed " << seed;
      if (w[i] == 0.0) {
        ASSERT_EQ(c[i], 0u);
      }
      total += c[i];
    }
    EXPECT_EQ(total, count);
  }
}

// Multinomial draws: copies of particle i are Binomial(N, p_i). Over many repetitions the mean count must
// match N p_i and a chi-square statistic of one large draw must be plausible.
TEST(Resampling, MultinomialMatchesTheWeightsStatistically) {
  const std::vector<double> w = {0.05, 0.1, 0.0, 0.25, 0.4, 0.2};
  const std::size_t n = w.size();
  const std::size_t count = 500;
  const int repetitions = 400;
  std::vector<double> mean(n, 0.0);
  Rng rng(7);
  std::vector<std::uint32_t> ancestors(count);
  double chi2_sum = 0.0;
  for (int r = 0; r < repetitions; ++r) {
    resample(ResamplingMethod::kMultinomial, w.data(), n, count, rng, ancestors.data());
    ASSERT_TRUE(std::is_sorted(ancestors.begin(), ancestors.end()));
    const auto c = copies(ancestors, n);
    ASSERT_EQ(c[2], 0u);
    double chi2 = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      mean[i] += static_cast<double>(c[i]) / repetitions;
      if (w[i] > 0.0) {
        const double e = static_cast<double>(count) * w[i];
        chi2 += (static_cast<double>(c[i]) - e) * (static_cast<double>(c[i]) - e) / e;
      }
    }
    chi2_sum += chi2;
  }
  for (std::size_t i = 0; i < n; ++i) {
    const double p = w[i];
    const double sd_of_mean = std::sqrt(static_cast<double>(count) * p * (1 - p) / repetitions);
    EXPECT_NEAR(mean[i], static_cast<double>(count) * p, 4.0 * sd_of_mean + 1e-9) << "particle " << i;
  }
  // Chi-square with 4 degrees of freedom has mean 4 and variance 8; the mean of 400 lies within 4 +- 0.6.
  EXPECT_NEAR(chi2_sum / repetitions, 4.0, 0.6);
}

// Systematic resampling also spreads the copies: it never gives fewer than N / n - 1 copies of equal weights,
// where multinomial does (its variance is the reason systematic is the default).
TEST(Resampling, SystematicHasLessVarianceThanMultinomial) {
  const std::size_t n = 100, count = 1000;
  const std::vector<double> w(n, 1.0);
  std::vector<std::uint32_t> ancestors(count);
  Rng rng(3);
  resample(ResamplingMethod::kSystematic, w.data(), n, count, rng, ancestors.data());
  for (std::size_t c : copies(ancestors, n)) EXPECT_EQ(c, 10u);
  resample(ResamplingMethod::kMultinomial, w.data(), n, count, rng, ancestors.data());
  const auto c = copies(ancestors, n);
  EXPECT_GT(*std::max_element(c.begin(), c.end()) - *std::min_element(c.begin(), c.end()), 2u);
}

TEST(Resampling, DeterministicForTheSameStream) {
  Rng a(11), b(11);
  Rng wr(5);
  const std::vector<double> w = random_weights(50, wr);
  for (ResamplingMethod m :
       {ResamplingMethod::kSystematic, ResamplingMethod::kResidual, ResamplingMethod::kMultinomial}) {
    std::vector<std::uint32_t> x(77), y(77);
    resample(m, w.data(), w.size(), x.size(), a, x.data());
    resample(m, w.data(), w.size(), y.size(), b, y.data());
    EXPECT_EQ(x, y) << to_string(m);
  }
}

TEST(Resampling, RejectsWeightsWithoutMass) {
  Rng rng(1);
  std::vector<std::uint32_t> out(4);
  const std::vector<double> zero(3, 0.0);
  EXPECT_THROW(resample(ResamplingMethod::kSystematic, zero.data(), zero.size(), 4, rng, out.data()), Error);
  const std::vector<double> nan = {1.0, std::nan(""), 1.0};
  EXPECT_THROW(resample(ResamplingMethod::kMultinomial, nan.data(), nan.size(), 4, rng, out.data()), Error);
  const std::vector<double> negative = {1.0, -1.0};
  EXPECT_THROW(resample(ResamplingMethod::kResidual, negative.data(), negative.size(), 4, rng, out.data()), Error);
  EXPECT_THROW(parse_resampling_method("stratified-ish"), Error);
  EXPECT_EQ(parse_resampling_method("residual"), ResamplingMethod::kResidual);
}

TEST(Resampling, EffectiveSampleSize) {
  const std::vector<double> equal(40, 2.5);
  EXPECT_NEAR(effective_sample_size(equal.data(), equal.size()), 40.0, 1e-9);
  const std::vector<double> one = {0.0, 3.0, 0.0, 0.0};
  EXPECT_NEAR(effective_sample_size(one.data(), one.size()), 1.0, 1e-12);
  const std::vector<double> two = {1.0, 1.0, 0.0};
  EXPECT_NEAR(effective_sample_size(two.data(), two.size()), 2.0, 1e-12);
}

}  // namespace
}  // namespace tsdf_mcl
