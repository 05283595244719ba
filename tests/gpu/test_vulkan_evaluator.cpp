// GPU-vs-CPU agreement of the sensor update: endpoint_weight.comp against the CPU evaluator and reduce.comp
// against the CPU reduction, on lavapipe with the validation layers on (any validation message fails).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "tsdf_mcl/cpu/cpu_evaluator.hpp"
#include "tsdf_mcl/backends/make_evaluator.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"
#include "sensor_test_support.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {

using test::make_vulkan;
using test::vulkan_options;

// A binding cap that splits the map's block pool into three chunks (a power of two of blocks each), as a map
// beyond maxStorageBufferRange would be.
std::uint64_t three_chunk_binding_bytes(const TsdfMap& map) {
  std::uint64_t blocks = 1;
  while (3 * blocks < map.block_count()) blocks *= 2;
  return blocks * TsdfMap::kWordsPerBlock * sizeof(std::uint32_t);
}

void copy_particles(const ParticleArrays& from, const ParticleArrays& to, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) to.set(i, from.position(i), from.rotation(i));
}

void expect_summaries_close(const WeightSummary& gpu, const WeightSummary& cpu) {
  EXPECT_NEAR(gpu.max_log_weight, cpu.max_log_weight, 1e-5 * std::abs(cpu.max_log_weight) + 1e-5);
  EXPECT_NEAR(gpu.weight_sum, cpu.weight_sum, 1e-4 * cpu.weight_sum);
  for (int a = 0; a < 3; ++a)
    EXPECT_NEAR(gpu.mean_position[a], cpu.mean_position[a], 1e-4 * (1.0 + std::abs(cpu.mean_position[a])));
  for (int a = 0; a < 4; ++a) EXPECT_NEAR(gpu.quaternion_sum[a], cpu.quaternion_sum[a], 1e-4 * cpu.weight_sum);
  EXPECT_NEAR(gpu.fit_sum, cpu.fit_sum, 1e-4 * cpu.fit_sum);
}

struct Variant {
  Likelihood likelihood;
  Interpolation interpolation;
  bool uniform_points;   // points through the uniform-buffer view (scans up to 4096 points) or the storage buffer
  bool map_texel_views;  // map through texel-buffer views or the storage buffers
  bool split_pool;       // block pool in three chunks
  WeightLayout layout = WeightLayout::kInvocationPerParticle;
};

class VulkanVsCpu : public ::testing::TestWithParam<Variant> {};

TEST_P(VulkanVsCpu, LogWeightsAgreeOnRandomParticles) {
  const TsdfMap map = test::make_room_map();
  EvaluatorOptions options = vulkan_options();
  options.uniform_points = GetParam().uniform_points;
  options.map_texel_views = GetParam().map_texel_views;
  if (GetParam().split_pool) options.max_map_binding_bytes = three_chunk_binding_bytes(map);
  options.weight_layout = GetParam().layout;
  auto gpu = make_vulkan(map, options);
  ASSERT_TRUE(gpu);
  EXPECT_EQ(gpu->weight_layout(), GetParam().layout == WeightLayout::kSubgroupPerParticle ? "subgroup" : "invocation");
  CpuEvaluator cpu(map, 2);
  std::mt19937 rng(7);
  const std::size_t n = 2000;
  const std::size_t points = 515;  // not a multiple of the shader's batch of points: the tail loop runs too
  gpu->reserve(n, points);
  cpu.reserve(n, points);
  test::random_particles(cpu.particles(), n, rng, Eigen::Vector3f(-3.4f, -2.4f, -0.3f),
                         Eigen::Vector3f(3.4f, 2.4f, 3.3f));
  copy_particles(cpu.particles(), gpu->particles(), n);
  const auto scan = test::random_scan(points, rng);
  gpu->set_points(scan);
  cpu.set_points(scan);
  EndpointModel model;
  model.sigma_hit = 0.12f;
  model.likelihood = GetParam().likelihood;
  model.interpolation = GetParam().interpolation;
  model.weight_exponent = 0.3f;
  const Eigen::Quaternionf ref = Eigen::Quaternionf::UnitRandom();
  const WeightSummary g = gpu->evaluate(n, model, ref);
  const WeightSummary c = cpu.evaluate(n, model, ref);
  const ParticleArrays gp = gpu->particles();
  const ParticleArrays cp = cpu.particles();
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_NEAR(gp.log_weight[i], cp.log_weight[i], 1e-4 * std::abs(cp.log_weight[i]) + 1e-5) << "particle " << i;
  }
  expect_summaries_close(g, c);
  EXPECT_TRUE(std::isfinite(gpu->last_timings().evaluate_ms));
}

INSTANTIATE_TEST_SUITE_P(
    AllForms, VulkanVsCpu,
    ::testing::Values(
        Variant{Likelihood::kProduct, Interpolation::kNearest, true, true, false},
        Variant{Likelihood::kProduct, Interpolation::kNearest, false, false, false},
        Variant{Likelihood::kProduct, Interpolation::kNearest, true, true, true},
        Variant{Likelihood::kProduct, Interpolation::kNearest, true, false, true},
        Variant{Likelihood::kProduct, Interpolation::kTrilinear, true, true, false},
        Variant{Likelihood::kProduct, Interpolation::kTrilinear, true, false, true},
        Variant{Likelihood::kSum, Interpolation::kNearest, true, false, false},
        Variant{Likelihood::kSum, Interpolation::kTrilinear, false, true, true},
        // A subgroup per particle, the layout GPUs get (lavapipe: 8 lanes).
        Variant{Likelihood::kProduct, Interpolation::kNearest, true, true, false, WeightLayout::kSubgroupPerParticle},
        Variant{Likelihood::kProduct, Interpolation::kNearest, false, false, true, WeightLayout::kSubgroupPerParticle},
        Variant{Likelihood::kProduct, Interpolation::kTrilinear, true, true, true, WeightLayout::kSubgroupPerParticle},
        Variant{Likelihood::kSum, Interpolation::kNearest, true, true, false, WeightLayout::kSubgroupPerParticle}),
    [](const ::testing::TestParamInfo<Variant>& p) {
      return std::string(p.param.likelihood == Likelihood::kProduct ? "product_" : "sum_") +
             (p.param.interpolation == Interpolation::kNearest ? "nearest" : "trilinear") +
             (p.param.uniform_points ? "_uniform_points" : "_storage_points") +
             (p.param.map_texel_views ? "_texel_map" : "_storage_map") + (p.param.split_pool ? "_split_pool" : "") +
             (p.param.layout == WeightLayout::kSubgroupPerParticle ? "_subgroup_per_particle" : "");
    });

// reduce.comp at sizes around workgroup and subgroup boundaries, in both variants: its result must equal the CPU
// reduction of the very log-weights the GPU computed.
class VulkanReduction : public ::testing::TestWithParam<bool> {};

TEST_P(VulkanReduction, AwkwardParticleCounts) {
  const TsdfMap map = test::make_room_map();
  EvaluatorOptions options = vulkan_options();
  options.subgroup_reduction = GetParam();
  auto gpu = make_vulkan(map, options);
  ASSERT_TRUE(gpu);
  std::mt19937 rng(9);
  const auto scan = test::random_scan(8, rng);
  gpu->set_points(scan);
  EndpointModel model;
  model.sigma_hit = 0.2f;
  // 1,048,577: a million particles take one more reduction level than 100,003.
  for (std::size_t n : {1u, 2u, 7u, 8u, 9u, 63u, 64u, 65u, 255u, 256u, 1023u, 1024u, 1025u, 4097u, 100003u, 1048577u}) {
    SCOPED_TRACE(n);
    gpu->reserve(n, scan.size());
    test::random_particles(gpu->particles(), n, rng, Eigen::Vector3f(-3, -2, 0), Eigen::Vector3f(3, 2, 3));
    const Eigen::Quaternionf ref = Eigen::Quaternionf::UnitRandom();
    const WeightSummary g = gpu->evaluate(n, model, ref);
    const WeightSummary c = reduce_weights(gpu->particles(), n, ref, fit_constants(model, scan.size()));
    expect_summaries_close(g, c);
  }
}

INSTANTIATE_TEST_SUITE_P(SubgroupAndShared, VulkanReduction, ::testing::Values(true, false),
                         [](const ::testing::TestParamInfo<bool>& p) {
                           return p.param ? "subgroup" : "shared_memory";
                         });

// Both layouts of endpoint_weight.comp on a tracking-like set (particles within 0.3 m and 10 degrees of one pose,
// many reading the same blocks) of odd counts, around the subgroup layout's workgroup of particles, and after the
// model changes (the nearest lookup's table follows it).
TEST(VulkanEvaluator, BothLayoutsAgreeWithTheCpuOnAClusteredSetOfOddCounts) {
  const TsdfMap map = test::make_room_map();
  for (WeightLayout layout : {WeightLayout::kInvocationPerParticle, WeightLayout::kSubgroupPerParticle}) {
    EvaluatorOptions options = vulkan_options();
    options.weight_layout = layout;
    auto gpu = make_vulkan(map, options);
    ASSERT_TRUE(gpu);
    CpuEvaluator cpu(map, 2);
    std::mt19937 rng(5);
    std::normal_distribution<float> g(0.0f, 1.0f);
    const std::size_t most = 1001;
    gpu->reserve(most, 333);
    cpu.reserve(most, 333);
    const Eigen::Quaternionf heading(Eigen::AngleAxisf(0.7f, Eigen::Vector3f::UnitZ()));
    for (std::size_t i = 0; i < most; ++i) {
      const Eigen::Vector3f d = 0.3f * Eigen::Vector3f(g(rng), g(rng), 0.2f * g(rng));
      const Eigen::Vector3f w = 0.1f * Eigen::Vector3f(g(rng), g(rng), g(rng));
      const Eigen::Quaternionf q = heading * Eigen::Quaternionf(Eigen::AngleAxisf(w.norm(), w.normalized()));
      cpu.particles().set(i, Eigen::Vector3f(0.5f, 0.2f, 1.2f) + d, q.normalized());
    }
    copy_particles(cpu.particles(), gpu->particles(), most);
    const auto scan = test::random_scan(333, rng);
    gpu->set_points(scan);
    cpu.set_points(scan);
    for (float sigma : {0.1f, 0.25f}) {
      EndpointModel model;
      model.sigma_hit = sigma;
      for (std::size_t n : {1u, 31u, 33u, 1001u}) {
        SCOPED_TRACE(std::to_string(n) + " particles, sigma " + std::to_string(sigma) + ", " + gpu->weight_layout());
        gpu->evaluate(n, model, heading);
        cpu.evaluate(n, model, heading);
        for (std::size_t i = 0; i < n; ++i) {
          ASSERT_NEAR(gpu->particles().log_weight[i], cpu.particles().log_weight[i],
                      1e-4 * std::abs(cpu.particles().log_weight[i]) + 1e-5)
              << "particle " << i;
        }
      }
    }
  }
}

TEST(VulkanEvaluator, GrowingKeepsParticlesAndSwapUsesTheOtherSet) {
  const TsdfMap map = test::make_room_map();
  auto gpu = make_vulkan(map);
  ASSERT_TRUE(gpu);
  gpu->reserve(10, 4);
  gpu->particles().set(3, Eigen::Vector3f(1, 2, 3), Eigen::Quaternionf::Identity());
  gpu->reserve(50000, 20000);
  EXPECT_GE(gpu->particles().capacity, 50000u);
  EXPECT_EQ(gpu->particles().position(3), Eigen::Vector3f(1, 2, 3));
  std::mt19937 rng(1);
  const auto scan = test::random_scan(100, rng);
  gpu->set_points(scan);
  test::random_particles(gpu->spare_particles(), 100, rng, Eigen::Vector3f(-3, -2, 0), Eigen::Vector3f(3, 2, 3));
  gpu->swap_particles();
  EndpointModel model;
  gpu->evaluate(100, model, Eigen::Quaternionf::Identity());
  const ParticleArrays p = gpu->particles();
  for (std::size_t i = 0; i < 100; ++i) {
    ASSERT_NEAR(p.log_weight[i], reference_log_weight(map, model, p.position(i), p.rotation(i), scan),
                1e-4 * std::abs(p.log_weight[i]));
  }
}

// One evaluator switches between the uniform view (small scans) and the storage buffer (scans beyond it).
TEST(VulkanEvaluator, ScansBeyondTheUniformRangeUseTheStorageBuffer) {
  const TsdfMap map = test::make_room_map();
  auto gpu = make_vulkan(map);
  ASSERT_TRUE(gpu);
  std::mt19937 rng(3);
  const std::size_t n = 64;
  gpu->reserve(n, 5000);
  test::random_particles(gpu->particles(), n, rng, Eigen::Vector3f(-3, -2, 0), Eigen::Vector3f(3, 2, 3));
  EndpointModel model;
  for (std::size_t points : {100u, 5000u, 300u}) {
    SCOPED_TRACE(points);
    const auto scan = test::random_scan(points, rng);
    gpu->set_points(scan);
    gpu->evaluate(n, model, Eigen::Quaternionf::Identity());
    const ParticleArrays p = gpu->particles();
    for (std::size_t i = 0; i < n; ++i) {
      const double ref = reference_log_weight(map, model, p.position(i), p.rotation(i), scan);
      ASSERT_NEAR(p.log_weight[i], ref, 1e-4 * std::abs(ref)) << i;
    }
  }
}

// weigh(): evaluate()'s log-weights without the reduction pass, with the profiling queries off and on (the
// reduction's query and timestamp still close, or reading them would wait forever).
TEST(VulkanEvaluator, WeighingWithoutTheReductionGivesTheSameLogWeights) {
  const TsdfMap map = test::make_room_map();
  std::mt19937 rng(5);
  const auto scan = test::random_scan(300, rng);
  const std::size_t n = 1001;
  for (const bool profile : {false, true}) {
    SCOPED_TRACE(profile);
    EvaluatorOptions options = vulkan_options();
    options.profile = profile;
    auto gpu = make_vulkan(map, options);
    ASSERT_TRUE(gpu);
    gpu->reserve(n, scan.size());
    test::random_particles(gpu->particles(), n, rng, Eigen::Vector3f(-3, -2, 0), Eigen::Vector3f(3, 2, 3));
    gpu->set_points(scan);
    EndpointModel model;
    model.weight_exponent = 0.4f;
    gpu->evaluate(n, model, Eigen::Quaternionf::Identity());
    const ParticleArrays p = gpu->particles();
    const std::vector<float> evaluated(p.log_weight, p.log_weight + n);
    std::fill(p.log_weight, p.log_weight + n, 0.0f);
    gpu->weigh(n, model);
    EXPECT_EQ(std::vector<float>(p.log_weight, p.log_weight + n), evaluated);
    EXPECT_GT(gpu->last_timings().evaluate_ms, 0.0);
    if (profile) {
      EXPECT_GT(gpu->last_timings().weight_invocations, 0u);
    }
    gpu->weigh(0, model);  // nothing to weigh
  }
}

TEST(VulkanEvaluator, BadInputIsAnError) {
  const TsdfMap map = test::make_room_map();
  auto gpu = make_vulkan(map);
  ASSERT_TRUE(gpu);
  EndpointModel model;
  gpu->reserve(8, 8);
  EXPECT_THROW(gpu->evaluate(8, model, Eigen::Quaternionf::Identity()), Error);  // no points yet
  EXPECT_THROW(gpu->set_points({Eigen::Vector3f(0, NAN, 0)}), Error);
  gpu->set_points({Eigen::Vector3f(1, 0, 0)});
  EXPECT_THROW(gpu->evaluate(gpu->particles().capacity + 1, model, Eigen::Quaternionf::Identity()), Error);
  model.z_rand = 0.0f;
  EXPECT_THROW(gpu->evaluate(1, model, Eigen::Quaternionf::Identity()), Error);
  EXPECT_THROW(make_evaluator(TsdfMap(), vulkan_options()), Error);
}

}  // namespace
}  // namespace tsdf_mcl
