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

// The filter's reason, the rivals it follows, the places with the best one's share, the fit and the coverage.
TEST(StatusContent, EachStateSaysWhy) {
  FilterStep step;
  step.state = TrackState::kSearching;
  step.reason = StateReason::kSpread;
  EXPECT_EQ(state_reason(step), "no compact place holds the belief; 0 places, the best holds 0 % of the belief");
  Place a, b;
  a.weight = 0.55;
  b.weight = 0.45;
  b.pose = pose_from_xyz_rpy(10, 0, 0, 0, 0, M_PI);
  step.estimate.places = {a, b};
  step.estimate.inlier_ratio = 0.9;
  step.estimate.coverage = 0.25;
  step.state = TrackState::kAmbiguous;
  step.reason = StateReason::kRivalUndecided;
  step.rivals = {b.pose};
  EXPECT_EQ(state_reason(step),
            "a look-alike not yet refuted (1 followed); 2 places, the best holds 55 % of the belief; 90 % of the scan "
            "fits, the map covers 25 %");
  step.state = TrackState::kUnmapped;
  step.reason = StateReason::kMapCoversLittle;
  step.rivals.clear();
  EXPECT_EQ(state_reason(step),
            "the map covers too little of the scan; 2 places, the best holds 55 % of the belief; 90 % of the scan "
            "fits, the map covers 25 %");
  step.state = TrackState::kConverged;
  step.reason = StateReason::kProven;
  step.estimate.places = {a};
  EXPECT_EQ(state_reason(step),
            "every rival refuted; 1 place, the best holds 55 % of the belief; 90 % of the scan fits, the map covers "
            "25 %");
  step.estimate.places = {a, b};
  EXPECT_EQ(places_text(step.estimate.places),
            "55 % at (0.00, 0.00, 0.00, yaw 0 deg); 45 % at (10.00, 0.00, 0.00, yaw 180 deg)");
  EXPECT_EQ(positions_text(step.rivals), "");
  EXPECT_EQ(positions_text({b.pose, a.pose}), "(10.00, 0.00, 0.00); (0.00, 0.00, 0.00)");
}

}  // namespace
}  // namespace tsdf_mcl::node
