// GPU-vs-CPU agreement on real data: a map integrated from real LiDAR scans and a real scan from another
// position (../shared/data/balm_realworld), particles around the true pose.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "tsdf_mcl/cpu/cpu_evaluator.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"
#include "sensor_test_support.hpp"
#include "checkout_paths.hpp"

namespace tsdf_mcl {
namespace {

const std::filesystem::path kBalm = std::filesystem::path(tsdf_mcl::test::shared_data_dir()) / "balm_realworld";

TEST(VulkanRealScan, WeightsAgreeWithCpuOnBalmRealworld) {
  if (!std::filesystem::exists(kBalm / "times.txt")) GTEST_SKIP() << "shared data absent: " << kBalm;
  const Dataset ds = Dataset::open(kBalm);
  ScanMapOptions map_options;
  map_options.voxel_size = 0.1f;
  const TsdfMap map = build_map_from_scans(ds, ScanSelection{0, 16, 0}.indices(ds.size()), map_options);
  const std::size_t k = 33;  // odd: not in the map
  const PointCloud scan = ds.load_scan(k);
  std::vector<Eigen::Vector3f> points;
  for (std::size_t i = 0; i < 1024; ++i) points.push_back(scan.points[i * scan.size() / 1024]);

  const std::unique_ptr<SensorEvaluator> gpu = test::make_vulkan(map);
  ASSERT_TRUE(gpu);
  CpuEvaluator cpu(map, 2);
  const std::size_t n = 3000;
  gpu->reserve(n, points.size());
  cpu.reserve(n, points.size());
  std::mt19937 rng(4);
  std::normal_distribution<float> g(0.0f, 1.0f);
  const Eigen::Vector3f t = ds.pose(k).translation().cast<float>();
  const Eigen::Quaternionf q(ds.pose(k).linear().cast<float>());
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f aa = Eigen::Vector3f(g(rng), g(rng), g(rng)) * 0.1f;
    const Eigen::Quaternionf qi = (q * Eigen::Quaternionf(Eigen::AngleAxisf(aa.norm(), aa.normalized()))).normalized();
    const Eigen::Vector3f ti = t + Eigen::Vector3f(g(rng), g(rng), 0.2f * g(rng)) * 0.5f;
    gpu->particles().set(i, ti, qi);
    cpu.particles().set(i, ti, qi);
  }
  gpu->set_points(points);
  cpu.set_points(points);
  for (Interpolation interpolation : {Interpolation::kNearest, Interpolation::kTrilinear}) {
    EndpointModel model;
    model.interpolation = interpolation;
    const WeightSummary gs = gpu->evaluate(n, model, q);
    const WeightSummary cs = cpu.evaluate(n, model, q);
    for (std::size_t i = 0; i < n; ++i) {
      const float c = cpu.particles().log_weight[i];
      ASSERT_NEAR(gpu->particles().log_weight[i], c, 1e-4f * std::abs(c)) << "particle " << i;
    }
    EXPECT_NEAR(gs.max_log_weight, cs.max_log_weight, 1e-4 * std::abs(cs.max_log_weight));
    EXPECT_NEAR(gs.weight_sum, cs.weight_sum, 1e-3 * cs.weight_sum);
    EXPECT_LT((gs.mean_position - cs.mean_position).norm(), 1e-3);
    // The map and the model are meaningful: the true pose explains the scan about as well as the best of
    // 3000 perturbed particles (ground-truth poses carry centimetres of error themselves).
    EXPECT_GT(reference_log_weight(map, model, t, q, points), cs.max_log_weight - 0.02 * std::abs(cs.max_log_weight));
  }
}

}  // namespace
}  // namespace tsdf_mcl
