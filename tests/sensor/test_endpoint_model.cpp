// The endpoint model's likelihood at known distances against its formula written out here, not against a reference
// that shares the library's constants: p(d) = z_hit / (sigma sqrt(2 pi)) exp(-d^2 / (2 sigma^2)) + z_rand / max_range,
// and p_rand = z_rand / max_range for a point in unknown space. Checked on the constants, the nearest-lookup table
// both backends read, and the default (nearest) path of the CPU evaluator and of every Vulkan variant.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "sensor_test_support.hpp"
#include "tsdf_mcl/cpu/cpu_evaluator.hpp"
#include "tsdf_mcl/sensor/endpoint_kernel.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kSigma = 0.1, kZHit = 0.8, kZRand = 0.2, kMaxRange = 40.0;

// The formula, in double, with its constants spelled out.
double written_out(double d) {
  const double pi = 3.14159265358979323846;
  return kZHit / (kSigma * std::sqrt(2.0 * pi)) * std::exp(-d * d / (2.0 * kSigma * kSigma)) + kZRand / kMaxRange;
}

EndpointModel model(Likelihood likelihood = Likelihood::kProduct) {
  EndpointModel m;
  m.sigma_hit = static_cast<float>(kSigma);
  m.z_hit = static_cast<float>(kZHit);
  m.z_rand = static_cast<float>(kZRand);
  m.max_range = static_cast<float>(kMaxRange);
  m.likelihood = likelihood;
  return m;
}

TEST(EndpointModel, LikelihoodAtKnownDistancesIsTheWrittenOutFormula) {
  const kernel::ModelConstants k(model());
  for (const double d : {0.0, 0.03, -0.05, 0.1, 0.17, -0.25, 0.3}) {
    EXPECT_NEAR(k.likelihood(static_cast<float>(d)), written_out(d), 2e-6 * written_out(d)) << "d = " << d;
  }
  // One sigma out the Gaussian falls to exp(-1/2) of its peak: sigma in place of sigma^2 would give exp(-0.05).
  const double peak = written_out(0.0) - kZRand / kMaxRange;
  EXPECT_NEAR((k.likelihood(static_cast<float>(kSigma)) - kZRand / kMaxRange) / peak, std::exp(-0.5), 1e-5);
  EXPECT_NEAR(k.p_rand, kZRand / kMaxRange, 1e-9);
  EXPECT_NEAR(k.p_unknown, kZRand / kMaxRange, 1e-9) << "unknown space is a miss by default";
}

TEST(EndpointModel, NearestTableHoldsTheFormulaPerQuantizedDistance) {
  const float step = 0.3f / TsdfMap::kQuantMax;
  std::vector<float> table;
  kernel::likelihood_table(model(), step, table);
  ASSERT_EQ(table.size(), kernel::kTableSize);
  for (const int q : {0, 1000, -1000, 10922, -21845, 32767}) {
    const double d = static_cast<double>(q) * step;
    EXPECT_NEAR(table[static_cast<std::size_t>(q + 32768)], std::log(written_out(d)), 1e-5) << "q = " << q;
  }
  EXPECT_NEAR(table[static_cast<std::size_t>(TsdfMap::kUnknownValue + 32768)], std::log(kZRand / kMaxRange), 1e-6);
  kernel::likelihood_table(model(Likelihood::kSum), step, table);
  EXPECT_NEAR(table[32768 + 10922], written_out(10922 * static_cast<double>(step)), 1e-6);
}

// A map whose voxels at known offsets from the origin hold known distances, and the points at their centres.
struct KnownScene {
  TsdfMap map = TsdfMap::covering(0.1f, 0.3f, Eigen::Vector3f(-1, -1, -1), Eigen::Vector3f(1, 1, 1));
  std::vector<Eigen::Vector3f> points;
  std::vector<double> distances;  // as the map stores them (quantized); NaN: unknown

  KnownScene() {
    const std::vector<std::pair<Eigen::Vector3i, float>> set = {
        {{2, 0, 0}, 0.0f}, {{0, 3, 0}, 0.05f}, {{0, 0, 4}, 0.12f}, {{-3, 0, 0}, -0.2f}, {{1, -2, 2}, 0.27f}};
    for (const auto& [v, d] : set) map.set_distance(v, d);
    for (const auto& [v, d] : set) {
      points.push_back(map.center_of(v));
      distances.push_back(map.dequantize(map.quantized(v)));
      EXPECT_NEAR(distances.back(), d, 1e-4);
    }
    points.push_back(map.center_of({3, 3, 3}));            // in an allocated block, never observed
    points.push_back(Eigen::Vector3f(50.0f, 0.0f, 0.0f));  // outside the map
    distances.insert(distances.end(), 2, std::nan(""));
  }

  double expected_log_weight(Likelihood likelihood) const {
    double log_sum = 0.0, sum = 0.0;
    for (const double d : distances) {
      const double p = std::isnan(d) ? kZRand / kMaxRange : written_out(d);
      log_sum += std::log(p);
      sum += p;
    }
    return likelihood == Likelihood::kProduct ? log_sum : std::log(sum);
  }
};

// One particle at the origin, unrotated, weighed by `eval`: its log-weight.
double log_weight_at_origin(SensorEvaluator& eval, const KnownScene& scene, Likelihood likelihood) {
  eval.reserve(1, scene.points.size());
  eval.set_points(scene.points);
  eval.particles().set(0, Eigen::Vector3f::Zero(), Eigen::Quaternionf::Identity());
  eval.evaluate(1, model(likelihood), Eigen::Quaternionf::Identity());
  return eval.particles().log_weight[0];
}

TEST(EndpointModel, CpuEvaluatorWeighsKnownDistancesByTheFormula) {
  const KnownScene scene;
  for (const Likelihood l : {Likelihood::kProduct, Likelihood::kSum}) {
    CpuEvaluator eval(scene.map, 1);
    const double expected = scene.expected_log_weight(l);
    EXPECT_NEAR(log_weight_at_origin(eval, scene, l), expected, 1e-4 * std::abs(expected) + 1e-5)
        << (l == Likelihood::kProduct ? "product" : "sum");
  }
}

TEST(EndpointModel, VulkanEvaluatorWeighsKnownDistancesByTheFormula) {
  const KnownScene scene;
  for (const WeightLayout layout : {WeightLayout::kInvocationPerParticle, WeightLayout::kSubgroupPerParticle}) {
    for (const bool texel_views : {true, false}) {
      EvaluatorOptions options = test::vulkan_options();
      options.weight_layout = layout;
      options.map_texel_views = texel_views;
      auto gpu = test::make_vulkan(scene.map, options);
      ASSERT_TRUE(gpu);
      for (const Likelihood l : {Likelihood::kProduct, Likelihood::kSum}) {
        const double expected = scene.expected_log_weight(l);
        EXPECT_NEAR(log_weight_at_origin(*gpu, scene, l), expected, 1e-4 * std::abs(expected) + 1e-5)
            << "layout " << static_cast<int>(layout) << ", texel views " << texel_views << ", "
            << (l == Likelihood::kProduct ? "product" : "sum");
      }
    }
  }
}

}  // namespace
}  // namespace tsdf_mcl
