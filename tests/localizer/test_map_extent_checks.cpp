// Pose inputs checked against the map (tsdf_mcl/localizer/map_extent_checks.hpp), for every frontend: a value
// beyond the map (1e30 m, 1e300 m) is one error naming it, and a refused scan leaves the localizer as it was.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "filter_test_scene.hpp"
#include "error_message.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"
#include "tsdf_mcl/localizer/map_extent_checks.hpp"

namespace tsdf_mcl {
namespace {

using test::error_of;

struct Scene {
  TsdfMap map = test::make_office_map();
  std::vector<Pose> truth = test::office_trajectory(4);
  std::vector<std::vector<Eigen::Vector3f>> scans;
  Scene() {
    Rng rng(5);
    for (const Pose& p : truth) scans.push_back(test::simulate_scan(test::office_boxes(), p, rng));
  }
};
const Scene& scene() {
  static const Scene s;
  return s;
}

LocalizerOptions local_cpu_run() {
  LocalizerOptions o;
  o.evaluator.backend = Backend::kCpu;
  o.filter.initial_particles = 500;
  o.filter.kld.max_particles = 500;
  o.filter.kld.min_particles = 100;
  o.preprocessing.max_beams = 64;
  o.initial_pose = scene().truth[0];
  return o;
}

Pose at(double x, double y, double z) {
  Pose p = Pose::Identity();
  p.translation() = Eigen::Vector3d(x, y, z);
  return p;
}

TEST(MapExtentChecks, PositionsOutsideTheMapAreNamed) {
  const TsdfMap& map = scene().map;
  const Eigen::Vector3f lo = map.world_min(), hi = map.world_max();
  const Eigen::Vector3d mid = (0.5f * (lo + hi)).cast<double>();
  check_pose_in_map(map, at(mid.x(), mid.y(), mid.z()), "pose");
  check_pose_in_map(map, at(lo.x(), lo.y(), lo.z()), "pose");  // the box's corners are inside
  check_pose_in_map(map, at(hi.x(), hi.y(), hi.z()), "pose");
  for (int a = 0; a < 3; ++a) {
    for (const double v : {1e30, -1e300, static_cast<double>(hi[a]) + 0.01, static_cast<double>(lo[a]) - 0.01}) {
      Eigen::Vector3d p = mid;
      p[a] = v;
      const std::string e = error_of([&] { check_pose_in_map(map, at(p.x(), p.y(), p.z()), "pose"); });
      EXPECT_EQ(e.rfind("pose lies outside the map: " + std::string(a == 0 ? "x" : a == 1 ? "y" : "z"), 0), 0u) << e;
    }
  }
  Pose nan = at(mid.x(), mid.y(), mid.z());
  nan.translation().x() = std::nan("");
  EXPECT_NE(error_of([&] { check_pose_in_map(map, nan, "pose"); }).find("pose is not finite"), std::string::npos);
  Pose sheared = at(mid.x(), mid.y(), mid.z());
  sheared.linear()(0, 1) = 0.5;
  EXPECT_NE(error_of([&] { check_pose_in_map(map, sheared, "pose"); }).find("not a rigid transform"),
            std::string::npos);
}

TEST(MapExtentChecks, OptionsBeyondTheMapStopTheLocalizerBeforeItStarts) {
  const TsdfMap& map = scene().map;
  const double diagonal = map_diagonal(map);
  EXPECT_NEAR(diagonal, (map.world_max() - map.world_min()).cast<double>().norm(), 1e-9);
  const std::vector<std::pair<std::function<void(LocalizerOptions&)>, std::string>> cases = {
      {[](LocalizerOptions& o) { o.initial_pose = at(1e30, 0, 0); }, "the initial pose (init, initial_pose.*)"},
      {[](LocalizerOptions& o) { o.filter.local_init.sigma_xy = 1e300; }, "init_sigma_xy 1e+300 m is larger than"},
      {[](LocalizerOptions& o) { o.filter.local_init.sigma_z = 1e30; }, "init_sigma_z"},
      {[&](LocalizerOptions& o) { o.filter.local_init.sigma_xy = 1.01 * diagonal; }, "the map's diagonal"},
      {[](LocalizerOptions& o) { o.filter.motion.diffusion_xy = 1e30; }, "diffusion_xy"},
      {[](LocalizerOptions& o) { o.filter.motion.alpha1 = 1e30; }, "alpha1 1e+30 is more than 10"},
      {[](LocalizerOptions& o) { o.filter.motion.alpha6 = 10.5; }, "alpha6 10.5 is more than 10"},
      {[](LocalizerOptions& o) {
         o.filter.global_init.use_height_band = true;
         o.filter.global_init.max_height = 1e300;
       },
       "init_height_band 1e+300 m lies beyond the map's height"},
  };
  for (const auto& [edit, words] : cases) {
    LocalizerOptions o = local_cpu_run();
    edit(o);
    const std::string e = error_of([&] { Localizer(map, o); });
    EXPECT_NE(e.find(words), std::string::npos) << e;
  }
  LocalizerOptions fine = local_cpu_run();
  fine.filter.local_init.sigma_xy = 0.99 * diagonal;
  EXPECT_NO_THROW(Localizer(map, fine));
}

TEST(MapExtentChecks, ARefusedScanOrPoseLeavesTheLocalizerAsItWas) {
  const Scene& s = scene();
  Localizer localizer(s.map, local_cpu_run());
  localizer.process(0.0, s.scans[0], s.truth[0]);
  const Pose before = localizer.estimate().pose;
  Pose far = s.truth[1];
  far.translation().x() += 1e30;
  EXPECT_NE(error_of([&] { localizer.process(0.1, s.scans[1], far); }).find("the scan's odometry lies beyond"),
            std::string::npos);
  far.translation().x() = s.truth[1].translation().x() + 1.5 * map_diagonal(s.map);
  EXPECT_NE(error_of([&] { localizer.process(0.1, s.scans[1], far); }).find("more than the map's diagonal"),
            std::string::npos);
  EXPECT_NE(error_of([&] { localizer.process(1e300, s.scans[1], s.truth[1]); }).find("the scan's stamp"),
            std::string::npos);
  EXPECT_NE(error_of([&] { localizer.reset_to(at(1e30, 0, 0)); }).find("the initial pose lies outside the map"),
            std::string::npos);
  LocalInitSpread wide;
  wide.sigma_xy = 1e150;
  EXPECT_NE(error_of([&] { localizer.reset_to(s.truth[1], wide); }).find("sigma_xy"), std::string::npos);
  wide = LocalInitSpread{};
  wide.sigma_yaw = 1e150;
  EXPECT_NE(error_of([&] { localizer.reset_to(s.truth[1], wide); }).find("sigma_yaw must lie in [0, 2 pi]"),
            std::string::npos);
  EXPECT_EQ(localizer.summary().scans, 1u);
  EXPECT_TRUE(localizer.estimate().pose.isApprox(before));
  // The next good scan goes on from the last good odometry: the track is not lost.
  const ScanRecord& r = localizer.process(0.1, s.scans[1], s.truth[1]);
  EXPECT_TRUE(r.step.estimate.pose.matrix().allFinite());
  EXPECT_LT(test::translation_error(r.step.estimate.pose, s.truth[1]), 0.5);
  EXPECT_TRUE(localizer.last_odometry()->isApprox(s.truth[1]));
}

}  // namespace
}  // namespace tsdf_mcl
