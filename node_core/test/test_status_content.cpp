// What the node's pose and status messages hold (status_content.hpp): the covariance in ROS's frame, the decimated
// particles, and the reason for each state.
#include <gtest/gtest.h>

#include <cmath>

#include "status_content.hpp"

namespace tsdf_mcl::node {
namespace {

TEST(StatusContent, CovarianceRotationTurnsIntoTheFixedFrame) {
  // Rotation uncertainty about the body's x axis only; the body is yawed 90 degrees, so in the fixed frame the
  // uncertainty is about y.
  const Pose mean = pose_from_xyz_rpy(0, 0, 0, 0, 0, M_PI / 2);
  Matrix6d body = Matrix6d::Zero();
  body(0, 0) = 0.04;  // x position
  body(3, 3) = 0.01;  // rotation about body x
  const std::array<double, 36> c = fixed_frame_covariance(mean, body);
  EXPECT_NEAR(c[0], 0.04, 1e-12);
  EXPECT_NEAR(c[3 * 6 + 3], 0.0, 1e-12);
  EXPECT_NEAR(c[4 * 6 + 4], 0.01, 1e-12);
}

TEST(StatusContent, ParticlesAreDecimatedToTheCap) {
  ParticleSnapshot snapshot;
  for (int i = 0; i < 10; ++i) {
    ParticleSnapshot::Particle p;
    p.position = Eigen::Vector3f(static_cast<float>(i), 0, 0);
    p.weight = 0.1f;
    snapshot.particles.push_back(p);
  }
  const PosesOut out = decimated_particles(snapshot, 4, Stamp{5}, "map");
  ASSERT_EQ(out.poses.size(), 4u);  // every third: 0, 3, 6, 9
  EXPECT_DOUBLE_EQ(out.poses[3].translation().x(), 9.0);
  EXPECT_FLOAT_EQ(static_cast<float>(out.weights[1]), 0.1f);
  EXPECT_EQ(decimated_particles(snapshot, 100, Stamp{5}, "map").poses.size(), 10u);
}

TEST(StatusContent, EachStateSaysWhy) {
  LocalizerOptions options;
  options.filter.convergence.min_inlier_ratio = 0.5;
  FilterStep step;
  step.state = TrackState::kSearching;
  EXPECT_EQ(state_reason(step, options), "global search: no place found yet");
  Hypothesis a, b;
  a.weight = 0.55;
  b.weight = 0.45;
  b.pose = pose_from_xyz_rpy(10, 0, 0, 0, 0, M_PI);
  step.estimate.hypotheses = {a, b};
  step.estimate.inlier_ratio = 0.9;
  step.estimate.coverage = 0.25;
  EXPECT_EQ(state_reason(step, options), "global search: 2 places, the best holds 55 % of the belief");
  step.state = TrackState::kAmbiguous;
  EXPECT_EQ(state_reason(step, options), "2 places explain the scans; the best holds 55 % of the belief");
  step.look_alikes = {b.pose};
  EXPECT_EQ(state_reason(step, options), "1 look-alike places not yet told from the track by the scans");
  step.state = TrackState::kConverged;
  EXPECT_EQ(state_reason(step, options), "one place holds 55 % of the belief and 90 % of the scan fits the map there");
  step.state = TrackState::kUnmapped;
  EXPECT_EQ(state_reason(step, options), "the map covers 25 % of the scan here: odometry carries the pose");
  step.state = TrackState::kLost;
  step.estimate.inlier_ratio = 0.2;
  EXPECT_EQ(state_reason(step, options),
            "20 % of the scan fits the map at the track (converged needs 50 %): searching "
            "the map again");
  step.state = TrackState::kTracking;
  EXPECT_EQ(state_reason(step, options),
            "following the track: the best place holds 55 %, 20 % of the scan fits "
            "(converged needs 50 % and one place)");
  EXPECT_EQ(hypotheses_text(step.estimate.hypotheses),
            "55 % at (0.00, 0.00, 0.00, yaw 0 deg); 45 % at (10.00, 0.00, 0.00, yaw 180 deg)");
}

}  // namespace
}  // namespace tsdf_mcl::node
