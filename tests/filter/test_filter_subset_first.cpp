// Subset-first weighing (subset_first.hpp): which particles get the whole scan, what the others keep, and that
// the two passes agree between the CPU evaluator and endpoint_weight.comp on lavapipe (validation layers on).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "sensor_test_support.hpp"
#include "tsdf_mcl/cpu/cpu_evaluator.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/subset_first.hpp"

namespace tsdf_mcl {
namespace {

constexpr std::size_t kParticles = 3001;  // odd: the refined share and the SIMD groups end mid-way
constexpr std::size_t kPoints = 203;

SubsetFirstOptions small_sets() {
  SubsetFirstOptions o;
  o.points = 24;
  o.share = 0.25;
  o.min_particles = 1000;
  o.global_points = 0;  // no middle pass
  return o;
}

// In a global search: every particle on 24 points, the best quarter on 64 (the first pass's 24 among them), the
// best tenth on all 203.
SubsetFirstOptions three_passes() {
  SubsetFirstOptions o = small_sets();
  o.points = 40;  // two passes' first (not in a global search)
  o.global_points = 24;
  o.middle_points = 64;
  o.whole_share = 0.1;
  return o;
}
constexpr bool kGlobalSearch = true;

EndpointModel tempered_model() {
  EndpointModel m;
  m.sigma_hit = 0.12f;
  m.weight_exponent = 0.3f;
  return m;
}

struct Scene {
  TsdfMap map = test::make_room_map();
  std::vector<float> positions;  // the random particles, to place them in any evaluator
  std::vector<Eigen::Vector3f> scan;
  Scene() {
    std::mt19937 rng(11);
    std::vector<float> storage(8 * kParticles);
    const ParticleArrays p = ParticleArrays::over(storage.data(), kParticles);
    test::random_particles(p, kParticles, rng, Eigen::Vector3f(-3.4f, -2.4f, -0.3f), Eigen::Vector3f(3.4f, 2.4f, 3.3f));
    positions = storage;
    scan = test::random_scan(kPoints, rng);
  }
  void place(SensorEvaluator& e) const {
    e.reserve(kParticles, kPoints);
    const ParticleArrays from = ParticleArrays::over(const_cast<float*>(positions.data()), kParticles);
    for (std::size_t i = 0; i < kParticles; ++i) e.particles().set(i, from.position(i), from.rotation(i));
  }
};

std::vector<float> log_weights(SensorEvaluator& e, std::size_t n) {
  const ParticleArrays p = e.particles();
  return std::vector<float>(p.log_weight, p.log_weight + n);
}

TEST(SubsetFirst, TheBestShareGetsTheWholeScanTheRestTheScaledSubset) {
  const Scene s;
  const EndpointModel model = tempered_model();
  // What each particle scores on the whole scan, and on the first pass's points scaled to the whole scan.
  CpuEvaluator reference(s.map, 2);
  s.place(reference);
  reference.set_points(s.scan);
  reference.evaluate(kParticles, model, Eigen::Quaternionf::Identity());
  const std::vector<float> whole = log_weights(reference, kParticles);
  std::vector<Eigen::Vector3f> subset;
  for (std::size_t j = 0; j < 24; ++j) subset.push_back(s.scan[j * kPoints / 24]);
  EndpointModel scaled = model;
  scaled.weight_exponent = model.weight_exponent * static_cast<float>(kPoints) / 24.0f;
  reference.set_points(subset);
  reference.evaluate(kParticles, scaled, Eigen::Quaternionf::Identity());
  const std::vector<float> first = log_weights(reference, kParticles);

  CpuEvaluator cpu(s.map, 2);
  s.place(cpu);
  SubsetFirstWeighing weighing(small_sets());
  ASSERT_TRUE(weighing.applies(kParticles, kPoints, model, cpu));
  UpdateTimings timings;
  const WeightSummary summary =
      weighing.weigh(cpu, kParticles, s.scan, model, Eigen::Quaternionf::Identity(), &timings);
  const std::vector<std::uint32_t>& refined = weighing.refined();
  ASSERT_EQ(refined.size(), 751u);  // ceil(0.25 * 3001)
  ASSERT_TRUE(std::is_sorted(refined.begin(), refined.end()));
  std::vector<bool> is_refined(kParticles, false);
  for (std::uint32_t i : refined) is_refined[i] = true;
  float lowest_refined = 1e30f, highest_other = -1e30f;
  const std::vector<float> got = log_weights(cpu, kParticles);
  for (std::size_t i = 0; i < kParticles; ++i) {
    const float expected = is_refined[i] ? whole[i] : first[i];
    ASSERT_NEAR(got[i], expected, 1e-5f * std::abs(expected) + 1e-5f) << "particle " << i;
    if (is_refined[i])
      lowest_refined = std::min(lowest_refined, first[i]);
    else
      highest_other = std::max(highest_other, first[i]);
  }
  EXPECT_GE(lowest_refined, highest_other) << "the refined particles are the first pass's best";
  EXPECT_NEAR(summary.max_log_weight, *std::max_element(got.begin(), got.end()), 1e-5);
  EXPECT_GT(timings.evaluate_ms, 0.0);
  // The particles themselves are untouched (the second pass ran on copies in the spare set).
  const ParticleArrays original = ParticleArrays::over(const_cast<float*>(s.positions.data()), kParticles);
  for (std::size_t i = 0; i < kParticles; i += 97) EXPECT_EQ(cpu.particles().position(i), original.position(i));
}

TEST(SubsetFirst, AMiddlePassNarrowsTheShareBeforeTheWholeScan) {
  const Scene s;
  const EndpointModel model = tempered_model();
  // Each particle's log-weight on the first pass's points, on the middle pass's (the first's among them) and on
  // the whole scan, each scaled to the whole scan.
  std::vector<bool> in_first(kPoints, false), in_middle(kPoints, false);
  for (std::size_t j = 0; j < 24; ++j) in_first[j * kPoints / 24] = in_middle[j * kPoints / 24] = true;
  for (std::size_t j = 0; j < 64; ++j) in_middle[j * kPoints / 64] = true;
  CpuEvaluator reference(s.map, 2);
  s.place(reference);
  const auto score = [&](const std::vector<bool>& used) {
    std::vector<Eigen::Vector3f> subset;
    for (std::size_t j = 0; j < kPoints; ++j) {
      if (used[j]) subset.push_back(s.scan[j]);
    }
    EndpointModel scaled = model;
    scaled.weight_exponent = model.weight_exponent * static_cast<float>(kPoints) / static_cast<float>(subset.size());
    reference.set_points(subset);
    reference.evaluate(kParticles, scaled, Eigen::Quaternionf::Identity());
    return log_weights(reference, kParticles);
  };
  const std::vector<float> first = score(in_first), middle = score(in_middle),
                           whole = score(std::vector<bool>(kPoints, true));

  CpuEvaluator cpu(s.map, 2);
  s.place(cpu);
  SubsetFirstWeighing weighing(three_passes());
  const WeightSummary summary =
      weighing.weigh(cpu, kParticles, s.scan, model, Eigen::Quaternionf::Identity(), nullptr, kGlobalSearch);
  ASSERT_EQ(weighing.middle().size(), 751u);   // ceil(0.25 * 3001)
  ASSERT_EQ(weighing.refined().size(), 301u);  // ceil(0.1 * 3001)
  ASSERT_TRUE(std::is_sorted(weighing.middle().begin(), weighing.middle().end()));
  ASSERT_TRUE(std::includes(weighing.middle().begin(), weighing.middle().end(), weighing.refined().begin(),
                            weighing.refined().end()));
  std::vector<int> pass(kParticles, 0);  // the last pass that weighed each particle
  for (std::uint32_t i : weighing.middle()) pass[i] = 1;
  for (std::uint32_t i : weighing.refined()) pass[i] = 2;
  const std::vector<float> got = log_weights(cpu, kParticles);
  float lowest[3] = {1e30f, 1e30f, 1e30f}, highest[3] = {-1e30f, -1e30f, -1e30f};
  for (std::size_t i = 0; i < kParticles; ++i) {
    const float expected = pass[i] == 2 ? whole[i] : pass[i] == 1 ? middle[i] : first[i];
    // Each point is weighed once per particle and the sums combined, so the terms match up to float rounding.
    ASSERT_NEAR(got[i], expected, 1e-4f * std::abs(expected) + 1e-4f) << "particle " << i << " of pass " << pass[i];
    const float ranked_by = pass[i] == 0 ? first[i] : middle[i];
    if (pass[i] >= 1) lowest[1] = std::min(lowest[1], first[i]);
    if (pass[i] == 0) highest[1] = std::max(highest[1], first[i]);
    if (pass[i] == 2) lowest[2] = std::min(lowest[2], ranked_by);
    if (pass[i] == 1) highest[2] = std::max(highest[2], ranked_by);
  }
  EXPECT_GE(lowest[1] + 1e-3f, highest[1]) << "the middle pass weighs the first pass's best";
  EXPECT_GE(lowest[2] + 1e-3f, highest[2]) << "the whole scan weighs the middle pass's best";
  EXPECT_NEAR(summary.max_log_weight, *std::max_element(got.begin(), got.end()), 1e-5);

  SubsetFirstOptions bad = three_passes();
  bad.whole_share = 0.0;
  EXPECT_THROW(SubsetFirstWeighing{bad}, Error);
}

TEST(SubsetFirst, OnlyAGlobalSearchTakesTheMiddlePass) {
  const Scene s;
  const EndpointModel model = tempered_model();
  // Within one place: two passes, the first on `points` (40), as without a middle pass.
  CpuEvaluator two(s.map, 2), cpu(s.map, 2);
  s.place(two);
  s.place(cpu);
  SubsetFirstOptions options = three_passes();
  options.global_points = 0;
  SubsetFirstWeighing without(options), within(three_passes());
  without.weigh(two, kParticles, s.scan, model, Eigen::Quaternionf::Identity(), nullptr, kGlobalSearch);
  within.weigh(cpu, kParticles, s.scan, model, Eigen::Quaternionf::Identity(), nullptr, !kGlobalSearch);
  EXPECT_TRUE(without.middle().empty());
  EXPECT_TRUE(within.middle().empty());
  EXPECT_EQ(within.refined(), without.refined());
  EXPECT_EQ(log_weights(cpu, kParticles), log_weights(two, kParticles));
}

TEST(SubsetFirst, TheMiddlePassNeedsMorePointsThanTheFirstAndAtMostHalfTheScan) {
  const Scene s;
  for (const std::size_t middle_points : {24u, 16u, 120u}) {  // the first pass's 24, fewer, over half of 203
    SCOPED_TRACE(middle_points);
    SubsetFirstOptions options = three_passes();
    options.middle_points = middle_points;
    CpuEvaluator cpu(s.map, 2);
    s.place(cpu);
    SubsetFirstWeighing weighing(options);
    weighing.weigh(cpu, kParticles, s.scan, tempered_model(), Eigen::Quaternionf::Identity(), nullptr, kGlobalSearch);
    EXPECT_TRUE(weighing.middle().empty());
    EXPECT_EQ(weighing.refined().size(), 751u) << "the share goes to the whole scan, as without a middle pass";
  }
  // No more particles on the whole scan than in the middle pass.
  SubsetFirstOptions options = three_passes();
  options.whole_share = 0.5;
  CpuEvaluator cpu(s.map, 2);
  s.place(cpu);
  SubsetFirstWeighing weighing(options);
  weighing.weigh(cpu, kParticles, s.scan, tempered_model(), Eigen::Quaternionf::Identity(), nullptr, kGlobalSearch);
  EXPECT_EQ(weighing.middle().size(), 751u);
  EXPECT_EQ(weighing.refined().size(), 751u);
}

TEST(SubsetFirst, SmallSetsAndTheSummedFormAreWeighedWhole) {
  const Scene s;
  SubsetFirstWeighing weighing(small_sets());
  EndpointModel model = tempered_model();
  CpuEvaluator cpu(s.map, 2), reference(s.map, 2);
  EXPECT_FALSE(weighing.applies(999, kPoints, model, cpu)) << "below min_particles";
  EXPECT_FALSE(weighing.applies(kParticles, 47, model, cpu)) << "a scan of fewer than twice the first pass's points";
  model.likelihood = Likelihood::kSum;
  EXPECT_FALSE(weighing.applies(kParticles, kPoints, model, cpu)) << "the summed form does not scale with the points";
  s.place(cpu);
  s.place(reference);
  weighing.weigh(cpu, kParticles, s.scan, model, Eigen::Quaternionf::Identity(), nullptr);
  EXPECT_TRUE(weighing.refined().empty());
  reference.set_points(s.scan);
  reference.evaluate(kParticles, model, Eigen::Quaternionf::Identity());
  EXPECT_EQ(log_weights(cpu, kParticles), log_weights(reference, kParticles));
  SubsetFirstOptions bad = small_sets();
  bad.share = 0.0;
  EXPECT_THROW(SubsetFirstWeighing{bad}, Error);
}

// An evaluator that says it runs on a discrete GPU (the CPU's arithmetic underneath).
class DiscreteGpuLike final : public SensorEvaluator {
 public:
  explicit DiscreteGpuLike(const TsdfMap& map) : cpu_(map, 2) {}
  std::string backend() const override { return "test"; }
  std::string device_name() const override { return "a discrete GPU"; }
  bool discrete_gpu() const override { return true; }
  void reserve(std::size_t particles, std::size_t points) override { cpu_.reserve(particles, points); }
  ParticleArrays particles() override { return cpu_.particles(); }
  ParticleArrays spare_particles() override { return cpu_.spare_particles(); }
  void swap_particles() override { cpu_.swap_particles(); }
  void set_points(const std::vector<Eigen::Vector3f>& points) override { cpu_.set_points(points); }
  WeightSummary evaluate(std::size_t n, const EndpointModel& model, const Eigen::Quaternionf& reference) override {
    ++evaluations;
    return cpu_.evaluate(n, model, reference);
  }
  const UpdateTimings& last_timings() const override { return cpu_.last_timings(); }
  int evaluations = 0;

 private:
  CpuEvaluator cpu_;
};

TEST(SubsetFirst, ADiscreteGpuWeighsTheWholeScanUnlessAsked) {
  const Scene s;
  const EndpointModel model = tempered_model();
  DiscreteGpuLike gpu(s.map);
  s.place(gpu);
  SubsetFirstWeighing weighing(small_sets());
  EXPECT_FALSE(weighing.applies(kParticles, kPoints, model, gpu));
  weighing.weigh(gpu, kParticles, s.scan, model, Eigen::Quaternionf::Identity(), nullptr);
  EXPECT_TRUE(weighing.refined().empty());
  EXPECT_EQ(gpu.evaluations, 1) << "one pass over the whole scan";
  SubsetFirstOptions asked = small_sets();
  asked.on_discrete_gpu = true;
  SubsetFirstWeighing forced(asked);
  EXPECT_TRUE(forced.applies(kParticles, kPoints, model, gpu));
  forced.weigh(gpu, kParticles, s.scan, model, Eigen::Quaternionf::Identity(), nullptr);
  EXPECT_EQ(gpu.evaluations, 3) << "two passes";
  EXPECT_FALSE(forced.refined().empty());
}

class SubsetFirstPasses : public ::testing::TestWithParam<bool> {};

TEST_P(SubsetFirstPasses, VulkanAgreesWithTheCpu) {
  const Scene s;
  SubsetFirstOptions options = GetParam() ? three_passes() : small_sets();
  options.on_discrete_gpu = true;  // the passes on every device
  const std::unique_ptr<SensorEvaluator> gpu = test::make_vulkan(s.map);
  ASSERT_TRUE(gpu);
  CpuEvaluator cpu(s.map, 2);
  s.place(*gpu);
  s.place(cpu);
  const EndpointModel model = tempered_model();
  SubsetFirstWeighing on_gpu(options), on_cpu(options);
  const WeightSummary g =
      on_gpu.weigh(*gpu, kParticles, s.scan, model, Eigen::Quaternionf::Identity(), nullptr, kGlobalSearch);
  const WeightSummary c =
      on_cpu.weigh(cpu, kParticles, s.scan, model, Eigen::Quaternionf::Identity(), nullptr, kGlobalSearch);
  // Float rounding may swap particles tied at the cut; elsewhere both chose alike and agree.
  std::vector<std::uint32_t> both;
  std::set_intersection(on_gpu.refined().begin(), on_gpu.refined().end(), on_cpu.refined().begin(),
                        on_cpu.refined().end(), std::back_inserter(both));
  EXPECT_GE(both.size() + 2, on_cpu.refined().size());
  EXPECT_EQ(on_gpu.middle().empty(), !GetParam());
  // Each particle's passes on either device: compared where they were the same.
  std::vector<int> gpu_passes(kParticles, 0), cpu_passes(kParticles, 0);
  for (std::uint32_t i : on_gpu.middle()) gpu_passes[i] |= 1;
  for (std::uint32_t i : on_gpu.refined()) gpu_passes[i] |= 2;
  for (std::uint32_t i : on_cpu.middle()) cpu_passes[i] |= 1;
  for (std::uint32_t i : on_cpu.refined()) cpu_passes[i] |= 2;
  const std::vector<float> gw = log_weights(*gpu, kParticles), cw = log_weights(cpu, kParticles);
  for (std::size_t i = 0; i < kParticles; ++i) {
    if (gpu_passes[i] != cpu_passes[i]) continue;
    ASSERT_NEAR(gw[i], cw[i], 1e-4f * std::abs(cw[i]) + 1e-5f) << "particle " << i;
  }
  EXPECT_NEAR(g.max_log_weight, c.max_log_weight, 1e-4 * std::abs(c.max_log_weight) + 1e-5);
  EXPECT_NEAR(g.weight_sum, c.weight_sum, 1e-3 * c.weight_sum);
}

INSTANTIATE_TEST_SUITE_P(TwoAndThree, SubsetFirstPasses, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& param) {
                           return param.param ? "WithAMiddlePass" : "TwoPasses";
                         });

}  // namespace
}  // namespace tsdf_mcl
