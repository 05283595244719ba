// ConvergenceMonitor: when the filter may say `converged` (convergence.hpp), update by update.
#include <gtest/gtest.h>

#include "tsdf_mcl/filter/convergence.hpp"

namespace tsdf_mcl {
namespace {

Pose at(double x, double y) { return pose_from_xyz_rpy(x, y, 0.5, 0.0, 0.0, 0.0); }
Pose forward(double d) { return pose_from_xyz_rpy(d, 0.0, 0.0, 0.0, 0.0, 0.0); }

// One dominant hypothesis at `pose` (with `inliers`), optionally a second one elsewhere.
PoseEstimate belief(const Pose& pose, double inliers, double second_weight = 0.0, double second_inliers = 0.0) {
  PoseEstimate e;
  e.pose = pose;
  e.inlier_ratio = inliers;
  Hypothesis top;
  top.pose = pose;
  top.weight = 1.0 - second_weight;
  top.inlier_ratio = inliers;
  e.hypotheses.push_back(top);
  if (second_weight > 0.0) {
    Hypothesis other;
    other.pose = pose * forward(10.0);
    other.weight = second_weight;
    other.inlier_ratio = second_inliers;
    e.hypotheses.push_back(other);
  }
  return e;
}

// Drives `updates` updates moving `step` m forward each, the belief following the odometry from `start`.
// Returns the number of the first update that said converged (0-based), or -1.
int drive(ConvergenceMonitor& m, const Pose& start, int updates, double step, double inliers, bool concentrated = true,
          double second_weight = 0.0, double second_inliers = 0.0) {
  Pose p = start;
  for (int k = 0; k < updates; ++k) {
    if (k > 0) p = p * forward(step);
    if (m.update(belief(p, inliers, second_weight, second_inliers), concentrated,
                 k > 0 ? forward(step) : Pose::Identity(), false, true))
      return k;
  }
  return -1;
}

ConvergenceOptions options() {
  ConvergenceOptions o;
  o.min_updates = 3;
  o.travel_after_jump_m = 5.0;
  return o;
}

TEST(ConvergenceMonitor, ConvergesAfterMinUpdatesAtOnePlace) {
  ConvergenceMonitor m(options());
  EXPECT_EQ(drive(m, at(0, 0), 10, 0.2, 0.9), 2);
}

TEST(ConvergenceMonitor, NeverWithAnImplausibleFitOrAMoreSpreadBelief) {
  ConvergenceMonitor m(options());
  EXPECT_EQ(drive(m, at(0, 0), 20, 0.2, 0.3), -1) << "inlier ratio below min_inlier_ratio";
  ConvergenceMonitor spread(options());
  EXPECT_EQ(drive(spread, at(0, 0), 20, 0.2, 0.9, false), -1) << "not concentrated";
}

TEST(ConvergenceMonitor, NeverWhileALookAlikeFitsNearlyAsWell) {
  ConvergenceMonitor m(options());
  EXPECT_EQ(drive(m, at(0, 0), 20, 0.2, 0.9, true, 0.01, 0.85), -1);
  ConvergenceMonitor weak(options());
  EXPECT_EQ(drive(weak, at(0, 0), 20, 0.2, 0.9, true, 0.01, 0.6), 2) << "a look-alike that fits clearly worse";
}

// The belief concentrated on one place (an operator's wrong initial pose) that never fitted well enough, then the
// background search moved it to a look-alike that fits plausibly: that place must hold over travel first.
TEST(ConvergenceMonitor, AChangeOfMindFromAConcentratedBeliefNeedsTravel) {
  ConvergenceMonitor m(options());
  EXPECT_EQ(drive(m, at(0, 0), 5, 0.2, 0.4), -1);
  // 0.2 m per update: 5 m of travel take 25 updates.
  const int first = drive(m, at(20, 5), 60, 0.2, 0.9);
  EXPECT_GE(first, 25);
  EXPECT_LE(first, 27);
}

TEST(ConvergenceMonitor, AJumpAfterConvergenceNeedsTravel) {
  ConvergenceMonitor m(options());
  ASSERT_EQ(drive(m, at(0, 0), 5, 0.2, 0.9), 2);
  const int first = drive(m, at(20, 5), 60, 0.2, 0.9);
  EXPECT_GE(first, 25);
}

TEST(ConvergenceMonitor, AWrongLockFoundOutNeedsTravel) {
  ConvergenceMonitor m(options());
  m.restart_after_wrong_lock();
  EXPECT_GE(drive(m, at(3, 3), 60, 0.2, 0.9), 25);
  m.reset();
  EXPECT_EQ(drive(m, at(3, 3), 60, 0.2, 0.9), 2) << "reset() forgets the doubt";
}

}  // namespace
}  // namespace tsdf_mcl
