#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "tsdf_mcl/cpu/endpoint_avx2.hpp"
#include "tsdf_mcl/cpu/endpoint_neon.hpp"
#include "tsdf_mcl/cpu/cpu_evaluator.hpp"
#include "sensor_test_support.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {

struct Case {
  Likelihood likelihood;
  Interpolation interpolation;
};

class CpuEvaluatorVsReference : public ::testing::TestWithParam<Case> {};

TEST_P(CpuEvaluatorVsReference, LogWeightsMatchTheDoubleReference) {
  const TsdfMap map = test::make_room_map();
  std::mt19937 rng(11);
  CpuEvaluator eval(map, 2);
  const std::size_t n = 300;
  eval.reserve(n, 700);
  test::random_particles(eval.particles(), n, rng, Eigen::Vector3f(-3.2f, -2.2f, 0.2f),
                         Eigen::Vector3f(3.2f, 2.2f, 2.8f));
  const auto scan = test::random_scan(700, rng);
  eval.set_points(scan);
  EndpointModel model;
  model.sigma_hit = 0.15f;
  model.likelihood = GetParam().likelihood;
  model.interpolation = GetParam().interpolation;
  model.weight_exponent = 0.5f;
  eval.evaluate(n, model, Eigen::Quaternionf::Identity());
  const ParticleArrays p = eval.particles();
  for (std::size_t i = 0; i < n; ++i) {
    const double ref = reference_log_weight(map, model, p.position(i), p.rotation(i), scan);
    ASSERT_NEAR(p.log_weight[i], ref, 1e-5 * std::abs(ref) + 1e-5) << "particle " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(AllForms, CpuEvaluatorVsReference,
                         ::testing::Values(Case{Likelihood::kProduct, Interpolation::kNearest},
                                           Case{Likelihood::kProduct, Interpolation::kTrilinear},
                                           Case{Likelihood::kSum, Interpolation::kNearest},
                                           Case{Likelihood::kSum, Interpolation::kTrilinear}),
                         [](const ::testing::TestParamInfo<Case>& p) {
                           return std::string(p.param.likelihood == Likelihood::kProduct ? "product_" : "sum_") +
                                  (p.param.interpolation == Interpolation::kNearest ? "nearest" : "trilinear");
                         });

TEST(CpuEvaluator, TruePoseOutweighsAShiftedOne) {
  const TsdfMap map = test::make_room_map(0.05f, 0.3f);
  // Points on the room's walls seen from (0, 0, 1.5).
  std::vector<Eigen::Vector3f> scan;
  for (int k = 0; k < 360; k += 3) {
    const float a = static_cast<float>(k) * 3.14159265f / 180.0f;
    const Eigen::Vector2f dir(std::cos(a), std::sin(a));
    const float tx = dir.x() > 0 ? 3.0f / dir.x() : (dir.x() < 0 ? -3.0f / dir.x() : 1e9f);
    const float ty = dir.y() > 0 ? 2.0f / dir.y() : (dir.y() < 0 ? -2.0f / dir.y() : 1e9f);
    const float t = std::min(tx, ty);
    const Eigen::Vector3f hit(dir.x() * t, dir.y() * t, 0.0f);
    // Skip beams that hit the pillar first.
    if ((Eigen::Vector2f(hit.x(), hit.y()) * 0.5f - Eigen::Vector2f(1.0f, 0.5f)).norm() < 1.0f) continue;
    scan.push_back(hit);
  }
  CpuEvaluator eval(map, 2);
  eval.reserve(2, scan.size());
  eval.set_points(scan);
  const ParticleArrays p = eval.particles();
  p.set(0, Eigen::Vector3f(0, 0, 1.5f), Eigen::Quaternionf::Identity());
  p.set(1, Eigen::Vector3f(0.25f, 0.1f, 1.5f), Eigen::Quaternionf::Identity());
  EndpointModel model;
  model.sigma_hit = 0.05f;
  const WeightSummary s = eval.evaluate(2, model, Eigen::Quaternionf::Identity());
  EXPECT_GT(p.log_weight[0], p.log_weight[1] + 10.0f);
  EXPECT_FLOAT_EQ(s.max_log_weight, p.log_weight[0]);
  EXPECT_NEAR(s.mean_position.x(), 0.0, 1e-3);
}

TEST(CpuEvaluator, RejectsBadInput) {
  const TsdfMap map = test::make_room_map();
  CpuEvaluator eval(map, 1);
  eval.reserve(4, 4);
  EndpointModel model;
  EXPECT_THROW(eval.evaluate(4, model, Eigen::Quaternionf::Identity()), Error);  // no points
  EXPECT_THROW(eval.set_points({Eigen::Vector3f(NAN, 0, 0)}), Error);
  eval.set_points({Eigen::Vector3f(1, 0, 0)});
  EXPECT_THROW(eval.evaluate(5, model, Eigen::Quaternionf::Identity()), Error);  // beyond capacity
  model.sigma_hit = 0.0f;
  EXPECT_THROW(eval.evaluate(1, model, Eigen::Quaternionf::Identity()), Error);
}

}  // namespace
}  // namespace tsdf_mcl

namespace tsdf_mcl {
namespace {

// The SIMD path the evaluator picked must give the scalar path's log-weights bit for bit: 1003 particles (not a
// multiple of 8 or 4, so short last groups), some far outside the map so lookups hit every kind of cell (outside,
// unknown, free, allocated), both likelihood forms.
void expect_simd_equals_scalar(const std::string& expected_path) {
  const TsdfMap map = test::make_room_map(0.05f, 0.3f);
  CpuEvaluator scalar(map, 2, false);
  CpuEvaluator simd(map, 2, true);
  ASSERT_EQ(std::string(scalar.simd_path()), "");
  ASSERT_EQ(std::string(simd.simd_path()), expected_path);
  std::mt19937 rng(21);
  const std::size_t n = 1003;
  scalar.reserve(n, 333);
  simd.reserve(n, 333);
  test::random_particles(scalar.particles(), n, rng, Eigen::Vector3f(-6, -5, -2), Eigen::Vector3f(6, 5, 5));
  for (std::size_t i = 0; i < n; ++i)
    simd.particles().set(i, scalar.particles().position(i), scalar.particles().rotation(i));
  const auto scan = test::random_scan(333, rng, 8.0f);
  scalar.set_points(scan);
  simd.set_points(scan);
  for (Likelihood form : {Likelihood::kProduct, Likelihood::kSum}) {
    EndpointModel model;
    model.likelihood = form;
    scalar.evaluate(n, model, Eigen::Quaternionf::Identity());
    simd.evaluate(n, model, Eigen::Quaternionf::Identity());
    for (std::size_t i = 0; i < n; ++i)
      ASSERT_EQ(simd.particles().log_weight[i], scalar.particles().log_weight[i]) << i;
  }
}

TEST(CpuEvaluator, SimdPathEqualsScalarPath) {
  if (!kernel::avx2_available()) GTEST_SKIP() << "this CPU has no AVX2 (the NEON twin is NeonPathEqualsScalarPath)";
  expect_simd_equals_scalar("AVX2");
}

// aarch64 builds (tools/test_arm64.sh runs them under qemu-aarch64): the evaluator must pick NEON and match.
TEST(CpuEvaluator, NeonPathEqualsScalarPath) {
  if (!kernel::neon_available()) GTEST_SKIP() << "not an aarch64 build";
  expect_simd_equals_scalar("NEON");
}

// The NEON kernel on sub-ranges that start and end off its 4-lane grid, against MapView lookups and the table
// summed in the scalar order; and it writes nothing outside [begin, end).
TEST(CpuEvaluator, NeonKernelMatchesScalarLookupsOnSubranges) {
  if (!kernel::neon_available()) GTEST_SKIP() << "not an aarch64 build";
  const TsdfMap map = test::make_room_map(0.05f, 0.3f);
  const kernel::MapView view(map);
  EndpointModel model;
  std::vector<float> table;
  kernel::likelihood_table(model, view.quant_step, table);
  CpuEvaluator holder(map, 1, false);
  std::mt19937 rng(5);
  const std::size_t n = 37;
  holder.reserve(n, 101);
  const ParticleArrays p = holder.particles();
  test::random_particles(p, n, rng, Eigen::Vector3f(-6, -5, -2), Eigen::Vector3f(6, 5, 5));
  const auto scan = test::random_scan(101, rng, 8.0f);
  std::vector<float> pts;
  for (const auto& q : scan) pts.insert(pts.end(), {q.x(), q.y(), q.z()});
  for (const auto& [begin, end] : {std::pair<std::size_t, std::size_t>{0, 37}, {3, 4}, {5, 14}, {30, 37}}) {
    std::vector<float> acc(n, -7.0f);
    kernel::accumulate_nearest_neon(view, table.data(), p, begin, end, pts.data(), scan.size(), acc.data());
    for (std::size_t i = 0; i < n; ++i) {
      if (i < begin || i >= end) {
        ASSERT_EQ(acc[i], -7.0f) << i;
        continue;
      }
      float r[9];
      kernel::rotation_matrix(p.qw[i], p.qx[i], p.qy[i], p.qz[i], r);
      const float t[3] = {p.x[i], p.y[i], p.z[i]};
      float expected = 0.0f;
      for (std::size_t j = 0; j < scan.size(); ++j) {
        float g[3];
        kernel::to_grid(r, t, view.inv_voxel, pts[3 * j], pts[3 * j + 1], pts[3 * j + 2], g);
        expected += table[kernel::sample_nearest(view, g) + 32768];
      }
      ASSERT_EQ(acc[i], expected) << i << " in [" << begin << ", " << end << ")";
    }
  }
}

}  // namespace
}  // namespace tsdf_mcl
