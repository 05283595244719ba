#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "tsdf_mcl/sensor/weight_reduction.hpp"

namespace tsdf_mcl {
namespace {

TEST(WeightReduction, MatchesDirectSumsAndIgnoresThreadCount) {
  const std::size_t n = 10007;
  std::vector<float> buf(8 * n);
  const ParticleArrays p = ParticleArrays::over(buf.data(), n);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (std::size_t i = 0; i < n; ++i) {
    p.set(i, Eigen::Vector3f(u(rng), u(rng), u(rng)), Eigen::Quaternionf::UnitRandom());
    p.log_weight[i] = -2000.0f + 30.0f * u(rng);
  }
  const Eigen::Quaternionf ref = Eigen::Quaternionf::UnitRandom();
  const FitConstants fit{1.0f / 1000.0f, 0.0f};
  const WeightSummary s = reduce_weights(p, n, ref, fit);
  double m = -1e300;
  for (std::size_t i = 0; i < n; ++i) m = std::max(m, static_cast<double>(p.log_weight[i]));
  double sw = 0, sx = 0, sq = 0, sf = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double w = std::exp(p.log_weight[i] - m);
    sw += w;
    sx += w * p.x[i];
    const double dot = p.qw[i] * ref.w() + p.qx[i] * ref.x() + p.qy[i] * ref.y() + p.qz[i] * ref.z();
    sq += w * (dot < 0 ? -p.qw[i] : p.qw[i]);
    sf += std::exp(p.log_weight[i] / 1000.0);
  }
  EXPECT_FLOAT_EQ(s.max_log_weight, static_cast<float>(m));
  EXPECT_NEAR(s.weight_sum, sw, 1e-9 * sw);
  EXPECT_NEAR(s.mean_position.x(), sx / sw, 1e-9);
  EXPECT_NEAR(s.quaternion_sum[0], sq, 1e-9 * std::abs(sw));
  EXPECT_NEAR(s.fit_sum, sf, 1e-6 * sf);
}

}  // namespace
}  // namespace tsdf_mcl
