#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/eval/trajectory_metrics.hpp"

namespace tsdf_mcl {
namespace {

struct Truth {
  std::vector<double> times;
  std::vector<Pose> poses;
};

Truth straight_line(std::size_t n) {
  Truth t;
  for (std::size_t i = 0; i < n; ++i) {
    t.times.push_back(1630577758.5 + 0.5 * static_cast<double>(i));
    t.poses.push_back(
        pose_from_xyz_rpy(0.3 * static_cast<double>(i), 1.0, 0.5, 0.0, 0.0, 0.1 * static_cast<double>(i)));
  }
  return t;
}

TEST(TrajectoryMetrics, ConvergenceLocalizedShareAndErrorsAfterConvergence) {
  const Truth t = straight_line(20);
  std::vector<StampedPose> est;
  for (std::size_t i = 0; i < 20; ++i) {
    Pose p = t.poses[i];
    if (i < 5)
      p.translation() += Eigen::Vector3d(2.0, 0, 0);  // lost at first
    else if (i == 7)
      p.translation() += Eigen::Vector3d(0, 0.2, 0);  // within 0.3 m: still localized
    else
      p.translation() += Eigen::Vector3d(0, 0.05, 0);
    if (i == 9) p.linear() = p.linear() * Eigen::AngleAxisd(0.07, Eigen::Vector3d::UnitX()).toRotationMatrix();  // 4°
    est.push_back({t.times[i], p});
  }
  const TrajectoryMetrics m = evaluate_trajectory(est, t.times, t.poses);
  ASSERT_TRUE(m.converged);
  EXPECT_EQ(m.convergence_index, 5u);
  EXPECT_NEAR(m.convergence_time, 2.5, 1e-9);
  EXPECT_NEAR(m.localized_fraction, 15.0 / 20.0, 1e-12);
  EXPECT_EQ(m.converged_count, 15u);
  EXPECT_NEAR(m.ate_rmse, std::sqrt((14 * 0.05 * 0.05 + 0.2 * 0.2) / 15.0), 1e-9);
  EXPECT_NEAR(m.rotation_rmse, std::sqrt(0.07 * 0.07 / 15.0), 1e-9);
  EXPECT_NEAR(m.max_translation_error, 0.2, 1e-9);
  EXPECT_NEAR(m.errors[0].translation.x(), 2.0, 1e-9);

  // A late failure moves the convergence point behind it.
  est[15].pose.linear() =
      est[15].pose.linear() * Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();  // 5.7°
  const TrajectoryMetrics late = evaluate_trajectory(est, t.times, t.poses);
  EXPECT_EQ(late.convergence_index, 16u);
  // Never localized at the end: not converged.
  est.back().pose.translation() += Eigen::Vector3d(1, 0, 0);
  const TrajectoryMetrics never = evaluate_trajectory(est, t.times, t.poses);
  EXPECT_FALSE(never.converged);
  EXPECT_EQ(never.ate_rmse, 0.0);
}

TEST(TrajectoryMetrics, MatchesTimestampsExactlyOrNearestWithinTolerance) {
  const Truth t = straight_line(10);
  std::vector<StampedPose> est = {{t.times[3] + 1e-7, t.poses[3]}, {t.times[6] - 0.01, t.poses[6]}};
  const TrajectoryMetrics m = evaluate_trajectory(est, t.times, t.poses);
  EXPECT_EQ(m.errors[0].truth_index, 3u);
  EXPECT_EQ(m.errors[1].truth_index, 6u);
  EXPECT_NEAR(m.errors[1].translation_norm, 0.0, 1e-12);
  est.push_back({t.times[8] + 0.2, t.poses[8]});  // between two scans, beyond the tolerance
  EXPECT_THROW(evaluate_trajectory(est, t.times, t.poses), Error);
  EXPECT_THROW(evaluate_trajectory({}, t.times, t.poses), Error);
  EXPECT_THROW(evaluate_trajectory(est, t.times, {}), Error);
}

// The localizer said "converged" at scans 3..19; it was 2 m off at 3 and 4 (false claims), within 1 m but 12°
// off at 12 (false by rotation), and right elsewhere; 0.9 m off at 2 without a claim counts for nothing.
TEST(TrajectoryMetrics, CountsFalseConvergenceClaims) {
  const Truth t = straight_line(20);
  std::vector<StampedPose> est;
  std::vector<bool> claims;
  for (std::size_t i = 0; i < 20; ++i) {
    Pose p = t.poses[i];
    if (i == 2) p.translation() += Eigen::Vector3d(0.9, 0, 0);
    if (i == 3 || i == 4) p.translation() += Eigen::Vector3d(0, 2.0, 0);
    if (i == 12) p.linear() = p.linear() * Eigen::AngleAxisd(0.21, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    if (i == 15) p.translation() += Eigen::Vector3d(0, 0, 0.95);  // off, but within the 1 m bound
    est.push_back({t.times[i], p});
    claims.push_back(i >= 3);
  }
  const TrajectoryMetrics m = evaluate_trajectory(est, t.times, t.poses, MetricsOptions{}, &claims);
  ASSERT_TRUE(m.has_claims);
  EXPECT_EQ(m.claimed_converged, 17u);
  EXPECT_EQ(m.false_convergence, 3u);
  EXPECT_EQ(m.first_false_index, 3u);
  EXPECT_NEAR(m.first_false_time, 1.5, 1e-9);
  // Without flags there is nothing to count; a wrong number of flags is an error.
  EXPECT_FALSE(evaluate_trajectory(est, t.times, t.poses).has_claims);
  claims.pop_back();
  EXPECT_THROW(evaluate_trajectory(est, t.times, t.poses, MetricsOptions{}, &claims), Error);
}

// 0.5 s between estimates. Far off at first (not found yet: no lost track); localized from 3; 5 m off at 6..10
// (2 s from the first to the last: not longer than lost_duration) and at 13..18 (2.5 s: a lost track, counted
// once); 0.9 m off at 20..25 is within lost_translation.
TEST(TrajectoryMetrics, CountsLostTracksOnlyAfterTheTrackWasFound) {
  const Truth t = straight_line(30);
  std::vector<StampedPose> est;
  for (std::size_t i = 0; i < 30; ++i) {
    Pose p = t.poses[i];
    if (i < 3 || (i >= 6 && i <= 10) || (i >= 13 && i <= 18)) p.translation() += Eigen::Vector3d(5.0, 0, 0);
    if (i >= 20 && i <= 25) p.translation() += Eigen::Vector3d(0, 0.9, 0);
    est.push_back({t.times[i], p});
  }
  const TrajectoryMetrics m = evaluate_trajectory(est, t.times, t.poses);
  EXPECT_EQ(m.lost_tracks, 1u);
  EXPECT_EQ(m.first_lost_index, 13u);
  EXPECT_NEAR(m.first_lost_time, 6.5, 1e-9);
  // Two more estimates off join both stretches into one episode (6..18): still one lost track, from 6 on.
  for (std::size_t i : {11u, 12u}) est[i].pose.translation() += Eigen::Vector3d(0, 3.0, 0);
  const TrajectoryMetrics joined = evaluate_trajectory(est, t.times, t.poses);
  EXPECT_EQ(joined.lost_tracks, 1u);
  EXPECT_EQ(joined.first_lost_index, 6u);
  MetricsOptions strict;
  strict.lost_translation = 0.5;  // the 0.9 m stretch (2.5 s) counts too
  EXPECT_EQ(evaluate_trajectory(est, t.times, t.poses, strict).lost_tracks, 2u);
}

}  // namespace
}  // namespace tsdf_mcl
