// The library's streaming localizer (tsdf_mcl/localizer/localizer.hpp), driven the way a ROS node drives it: scans and
// odometry one at a time, an operator's initial pose, a request to search the whole map again.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "filter_test_scene.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/localizer/localization_report.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"

namespace tsdf_mcl {
namespace {

constexpr double kScanPeriod = 0.1;

struct World {
  TsdfMap map = test::make_office_map();
  std::vector<Pose> truth = test::office_trajectory(30);
  std::vector<Pose> odometry = test::drifting_odometry(truth, 3);
  std::vector<std::vector<Eigen::Vector3f>> scans;
  World() {
    const std::vector<test::Box> boxes = test::office_boxes();
    Rng rng(11);
    for (const Pose& p : truth) scans.push_back(test::simulate_scan(boxes, p, rng));
  }
};
const World& world() {
  static const World w;
  return w;
}

LocalizerOptions small_cpu_run() {
  LocalizerOptions o;
  o.evaluator.backend = Backend::kCpu;
  o.filter.initial_particles = 20000;
  o.filter.kld.max_particles = 20000;
  o.filter.global_search.candidates = 200000;
  o.filter.update_min_d = 0.0;
  o.filter.update_min_a = 0.0;
  o.preprocessing.max_beams = 256;
  return o;
}

TEST(Localizer, FindsTheRobotFromNoInitialGuessAndSummarizesTheRun) {
  const World& w = world();
  Localizer localizer(w.map, small_cpu_run());
  EXPECT_EQ(localizer.evaluator().backend(), "cpu");
  EXPECT_NE(localizer.backend_note().find("cpu"), std::string::npos);
  EXPECT_FALSE(localizer.initialization().has_value()) << "the global search waits for the first scan";
  for (std::size_t i = 0; i < w.truth.size(); ++i) {
    const ScanRecord& r = localizer.process(kScanPeriod * static_cast<double>(i), w.scans[i], w.odometry[i]);
    EXPECT_EQ(r.index, i);
    EXPECT_TRUE(r.step.updated);
    EXPECT_EQ(r.points.output, 256u);
    if (r.step.estimate.converged) {
      EXPECT_LT(test::translation_error(r.step.estimate.pose, w.truth[i]), 0.3) << "converged while wrong at " << i;
    }
  }
  ASSERT_TRUE(localizer.initialization().has_value());
  EXPECT_TRUE(localizer.initialization()->global);
  EXPECT_EQ(localizer.initialization()->gravity_source, "scan");
  EXPECT_FALSE(localizer.initialization()->candidates.empty());
  const RunSummary s = localizer.summary();
  EXPECT_EQ(s.scans, w.truth.size());
  EXPECT_EQ(s.updates, w.truth.size());
  EXPECT_TRUE(s.converged);
  ASSERT_TRUE(s.converged_since_time.has_value());
  EXPECT_LT(*s.converged_since_time, 1.5);
  EXPECT_EQ(s.particles_max, 20000u);
  EXPECT_LT(s.particles_final, 20000u) << "KLD-sampling shrinks the set once it converged";
  EXPECT_GT(s.update_ms_mean, 0.0);
  EXPECT_LE(s.update_ms_median, s.update_ms_max);

  // The snapshot is the particle set with normalized weights; the records serialize.
  const ParticleSnapshot snapshot = localizer.snapshot();
  EXPECT_EQ(snapshot.particles.size(), s.particles_final);
  double sum = 0.0;
  for (const auto& p : snapshot.particles) sum += p.weight;
  EXPECT_NEAR(sum, 1.0, 1e-4);
  const nlohmann::json summary = summary_json(s);
  EXPECT_EQ(summary["filter_updates"], w.truth.size());
  EXPECT_EQ(initialization_json(*localizer.initialization())["mode"], "global");
}

TEST(Localizer, InitialPoseRelocalizationAndAnUpdateOnRequest) {
  const World& w = world();
  LocalizerOptions o = small_cpu_run();
  o.filter.initial_particles = 2000;
  o.filter.update_min_d = 0.5;  // the motion gate holds most scans (0.4 m apart)
  o.filter.update_min_a = 1.0;
  o.initial_pose = w.truth[0];
  Localizer localizer(w.map, o);
  ASSERT_TRUE(localizer.initialization().has_value());
  EXPECT_FALSE(localizer.initialization()->global);
  localizer.process(0.0, w.scans[0], w.odometry[0]);
  const ScanRecord& held = localizer.process(kScanPeriod, w.scans[1], w.odometry[1]);
  EXPECT_FALSE(held.step.updated) << "0.4 m is below update_min_d";
  localizer.request_update();
  const ScanRecord& forced = localizer.process(2 * kScanPeriod, w.scans[2], w.odometry[2]);
  EXPECT_TRUE(forced.step.updated) << "request_update() weighs the next scan whatever the motion";
  EXPECT_LT(test::translation_error(forced.step.estimate.pose, w.truth[2]), 0.3);

  // An operator's pose elsewhere: the particles go there now.
  localizer.reset_to(w.truth[20]);
  EXPECT_LT(test::translation_error(localizer.estimate().pose, w.truth[20]), 1e-6);
  const ScanRecord& after = localizer.process(3 * kScanPeriod, w.scans[20], w.odometry[20]);
  EXPECT_LT(test::translation_error(after.step.estimate.pose, w.truth[20]), 0.3);

  // A global search from the next scan, as the global_localization service asks.
  localizer.reset_global();
  localizer.process(4 * kScanPeriod, w.scans[21], w.odometry[21]);
  ASSERT_TRUE(localizer.initialization().has_value());
  EXPECT_TRUE(localizer.initialization()->global);
}

TEST(Localizer, BadInputIsAClearError) {
  const World& w = world();
  LocalizerOptions o = small_cpu_run();
  Localizer localizer(w.map, o);
  const std::vector<Eigen::Vector3f> close(10, Eigen::Vector3f(0.1f, 0.0f, 0.0f));
  try {
    localizer.process(0.0, close, w.odometry[0]);
    FAIL() << "a scan with no point in range must be an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("laser_min_range"), std::string::npos) << e.what();
  }
  EXPECT_THROW(localizer.process(0.0, w.scans[0], std::nullopt), Error) << "the odometry model needs odometry";
  localizer.add_imu({1.0, Eigen::Vector3d(0, 0, 9.81)});
  EXPECT_THROW(localizer.add_imu({0.5, Eigen::Vector3d(0, 0, 9.81)}), Error) << "IMU samples out of order";
  o.filter.initial_particles = 0;
  EXPECT_THROW(Localizer(w.map, o), Error);
}

}  // namespace
}  // namespace tsdf_mcl
