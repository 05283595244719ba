// The motion model's state between updates (motion_prediction.hpp): what each model predicts, and when the
// constant-velocity model learns or forgets its velocity.
#include <gtest/gtest.h>

#include "tsdf_mcl/filter/motion_prediction.hpp"

namespace tsdf_mcl {
namespace {

void expect_near(const Pose& a, const Pose& b) {
  EXPECT_TRUE(a.isApprox(b, 1e-9)) << "\n" << a.matrix() << "\nvs\n" << b.matrix();
}

TEST(MotionPrediction, OdometryGivesTheRelativeMotionSinceTheLastUpdate) {
  MotionPrediction m(MotionModelType::kOdometry);
  const Pose a = pose_from_xyz_rpy(1.0, 2.0, 0.5, 0.0, 0.0, 0.3);
  const Pose b = pose_from_xyz_rpy(1.5, 2.2, 0.5, 0.0, 0.05, 0.5);
  expect_near(m.delta(0.0, a), Pose::Identity());  // no update yet: nothing to move from
  EXPECT_EQ(m.elapsed(3.0), 0.0);
  m.finish_update(1.0, a);
  expect_near(m.delta(1.1, b), a.inverse() * b);
  EXPECT_DOUBLE_EQ(m.elapsed(1.25), 0.25);
  m.reset();  // a new belief: the next update is the first again
  EXPECT_FALSE(m.has_update());
  expect_near(m.delta(1.2, b), Pose::Identity());
}

TEST(MotionPrediction, ConstantVelocityStretchesTheLastLocalizedMotionOverTheTimePassed) {
  MotionPrediction m(MotionModelType::kConstantVelocity);
  const Pose p0 = pose_from_xyz_rpy(0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
  const Pose p1 = pose_from_xyz_rpy(0.4, 0.0, 0.0, 0.0, 0.0, 0.2);
  m.finish_update(0.0, std::nullopt);
  expect_near(m.delta(0.5, std::nullopt), Pose::Identity());  // no velocity learnt yet
  m.observe_estimate(1.0, p0, p1, true);                      // moved 0.4 m and 0.2 rad in 1 s
  m.finish_update(1.0, std::nullopt);
  const Pose half = m.delta(1.5, std::nullopt);
  EXPECT_NEAR(half.translation().norm(), 0.2, 1e-6);
  EXPECT_NEAR(Eigen::AngleAxisd(half.linear()).angle(), 0.1, 1e-9);
  const Pose twice = m.delta(3.0, std::nullopt);
  EXPECT_NEAR(Eigen::AngleAxisd(twice.linear()).angle(), 0.4, 1e-9);

  // A spread belief's estimate jumps: that is no motion, and the velocity is forgotten.
  m.observe_estimate(2.0, p1, pose_from_xyz_rpy(9.0, 4.0, 0.0, 0.0, 0.0, 2.0), false);
  m.finish_update(2.0, std::nullopt);
  expect_near(m.delta(2.5, std::nullopt), Pose::Identity());
  // Nor is an estimate at a time not after the last update's.
  m.observe_estimate(1.5, p0, p1, true);
  expect_near(m.delta(2.5, std::nullopt), Pose::Identity());
}

TEST(MotionPrediction, DiffusionPredictsNoMotionAndOtherModelsIgnoreTheVelocity) {
  MotionPrediction diffusion(MotionModelType::kDiffusion);
  MotionPrediction odometry(MotionModelType::kOdometry);
  const Pose p1 = pose_from_xyz_rpy(0.4, 0.0, 0.0, 0.0, 0.0, 0.2);
  for (MotionPrediction* m : {&diffusion, &odometry}) {
    m->finish_update(0.0, Pose::Identity());
    m->observe_estimate(1.0, Pose::Identity(), p1, true);
    m->finish_update(1.0, Pose::Identity());
  }
  expect_near(diffusion.delta(2.0, p1), Pose::Identity());
  expect_near(odometry.delta(2.0, p1), p1);  // the odometry's motion, not the estimate's
}

}  // namespace
}  // namespace tsdf_mcl
