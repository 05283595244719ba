// The tf tree of bag datasets (transform_tree.hpp): chains through static and moving frames, interpolation, and
// the errors that name the frames.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "error_message.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/transform_tree.hpp"

namespace tsdf_mcl {
namespace {

using test::error_of;

void expect_near(const Pose& a, const Pose& b, double tolerance = 1e-12) {
  EXPECT_LT((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), tolerance) << a.matrix() << "\n" << b.matrix();
}

// map -> odom (static), odom -> base_footprint (moving), base_footprint -> base_link -> lidar (static), and a
// camera beside the lidar.
TransformTree robot() {
  TransformTree tree;
  tree.add("map", "odom", 0.0, pose_from_xyz_rpy(1, 2, 0, 0, 0, 0.5), true);
  tree.add("odom", "base_footprint", 10.0, pose_from_xyz_rpy(0, 0, 0, 0, 0, 0), false);
  tree.add("odom", "base_footprint", 11.0, pose_from_xyz_rpy(2, 0, 0, 0, 0, 1.0), false);
  tree.add("odom", "base_footprint", 12.0, pose_from_xyz_rpy(2, 4, 0, 0, 0, 1.0), false);
  tree.add("base_footprint", "base_link", 0.0, pose_from_xyz_rpy(0, 0, 0.1, 0, 0, 0), true);
  tree.add("base_link", "lidar", 0.0, pose_from_xyz_rpy(0.2, 0, 0.5, 0, 0.1, 0), true);
  tree.add("base_link", "camera", 0.0, pose_from_xyz_rpy(0.3, 0.1, 0.4, 0, 0, -0.2), true);
  return tree;
}

TEST(TransformTree, ChainsAndInterpolation) {
  const TransformTree tree = robot();
  const Pose base_T_lidar = pose_from_xyz_rpy(0, 0, 0.1, 0, 0, 0) * pose_from_xyz_rpy(0.2, 0, 0.5, 0, 0.1, 0);
  // At a sample: exactly that sample.
  expect_near(tree.lookup("odom", "lidar", 11.0), pose_from_xyz_rpy(2, 0, 0, 0, 0, 1.0) * base_T_lidar);
  // A quarter of the way from 10 to 11 s: translation linear, yaw slerped.
  expect_near(tree.lookup("odom", "lidar", 10.25), pose_from_xyz_rpy(0.5, 0, 0, 0, 0, 0.25) * base_T_lidar, 1e-12);
  // Up and down the tree: map -> odom -> ... -> lidar.
  expect_near(tree.lookup("map", "lidar", 12.0),
              pose_from_xyz_rpy(1, 2, 0, 0, 0, 0.5) * pose_from_xyz_rpy(2, 4, 0, 0, 0, 1.0) * base_T_lidar);
  // Between siblings: static, any time.
  const Pose lidar_T_camera = tree.lookup("lidar", "camera", 123.0);
  expect_near(lidar_T_camera,
              pose_from_xyz_rpy(0.2, 0, 0.5, 0, 0.1, 0).inverse() * pose_from_xyz_rpy(0.3, 0.1, 0.4, 0, 0, -0.2));
  expect_near(tree.lookup("camera", "lidar", 0.0), lidar_T_camera.inverse());
  expect_near(tree.lookup("lidar", "lidar", 5.0), Pose::Identity());
  // Coverage: the moving edge's times where it is on the way, everything where it is not.
  EXPECT_EQ(tree.coverage("odom", "lidar"), std::make_pair(10.0, 12.0));
  EXPECT_TRUE(std::isinf(tree.coverage("base_link", "camera").first));
  EXPECT_TRUE(tree.has_frame("map") && tree.has_frame("camera") && !tree.has_frame("imu"));
  EXPECT_EQ(tree.edges(), 5u);
}

TEST(TransformTree, SamplesOutOfOrderAndRepeated) {
  TransformTree tree;
  tree.add("odom", "base", 2.0, pose_from_xyz_rpy(2, 0, 0, 0, 0, 0), false);
  tree.add("odom", "base", 0.0, pose_from_xyz_rpy(0, 0, 0, 0, 0, 0), false);
  tree.add("odom", "base", 1.0, pose_from_xyz_rpy(5, 0, 0, 0, 0, 0), false);
  tree.add("odom", "base", 1.0, pose_from_xyz_rpy(1, 0, 0, 0, 0, 0), false);  // replaces the one at 1 s
  expect_near(tree.lookup("odom", "base", 0.5), pose_from_xyz_rpy(0.5, 0, 0, 0, 0, 0));
  expect_near(tree.lookup("odom", "base", 1.5), pose_from_xyz_rpy(1.5, 0, 0, 0, 0, 0));
}

// A live stream keeps a window: samples more than `keep` before an edge's newest go, static edges stay.
TEST(TransformTree, ForgetsSamplesOlderThanTheWindow) {
  TransformTree tree = robot();
  tree.add("odom", "base_footprint", 30.0, pose_from_xyz_rpy(3, 4, 0, 0, 0, 1.0), false);
  tree.forget_older_than(18.5);  // keeps 11.5 .. 30 s: the samples at 12 and 30 s
  EXPECT_EQ(tree.coverage("odom", "lidar"), std::make_pair(12.0, 30.0));
  expect_near(tree.lookup("odom", "base_footprint", 21.0), pose_from_xyz_rpy(2.5, 4, 0, 0, 0, 1.0));
  EXPECT_NE(error_of([&] { tree.lookup("odom", "base_footprint", 11.0); }).find("is known from 12 to 30 s"),
            std::string::npos);
  expect_near(tree.lookup("lidar", "camera", 0.0), robot().lookup("lidar", "camera", 0.0));
  tree.forget_older_than(0.0);  // the newest sample alone
  EXPECT_EQ(tree.coverage("odom", "lidar"), std::make_pair(30.0, 30.0));
}

TEST(TransformTree, ErrorsNameTheFrames) {
  TransformTree tree = robot();
  tree.add("world", "mocap_marker", 0.0, Pose::Identity(), true);
  EXPECT_NE(error_of([&] {
              tree.lookup("odom", "mocap_marker", 11.0);
            }).find("no tf connects 'odom' and 'mocap_marker'; the tf frames are: base_footprint, base_link, camera"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              tree.lookup("base_link", "velodyne", 11.0);
            }).find("no tf connects 'base_link' and 'velodyne' ('velodyne' is in no tf message)"),
            std::string::npos);
  const std::string outside = error_of([&] { tree.lookup("odom", "lidar", 12.5); });
  EXPECT_NE(outside.find("tf 'odom' -> 'base_footprint' is known from 10 to 12 s, not at 12.5 s"), std::string::npos)
      << outside;
  EXPECT_NE(error_of([&] {
              tree.add("map", "base_link", 0.0, Pose::Identity(), true);
            }).find("frame 'base_link' has two parents, 'base_footprint' and 'map'"),
            std::string::npos);
  EXPECT_NE(error_of([&] {
              tree.add("odom", "base_footprint", 13.0, Pose::Identity(), true);
            }).find("both static (/tf_static) and dynamic (/tf)"),
            std::string::npos);
  EXPECT_NE(error_of([&] { tree.add("lidar", "lidar", 0.0, Pose::Identity(), true); }).find("to itself"),
            std::string::npos);
  TransformTree loop;
  loop.add("a", "b", 0.0, Pose::Identity(), true);
  loop.add("b", "a", 0.0, Pose::Identity(), true);
  EXPECT_NE(error_of([&] { loop.lookup("a", "c", 0.0); }).find("loop"), std::string::npos);
}

TEST(TransformTree, AbsurdOrNonFiniteTransformsAreOneError) {
  // A /tf_static extrinsic of 1e300 m made `localize --bag` write -nan trajectories with exit status 0.
  TransformTree tree;
  const std::string far =
      error_of([&] { tree.add("base_link", "lidar", 0.0, pose_from_xyz_rpy(1e300, 0, 0, 0, 0, 0), true); });
  EXPECT_NE(far.find("tf 'base_link' -> 'lidar': translation (1e+300, 0, 0) m is not finite or beyond 1e+06 m"),
            std::string::npos)
      << far;
  Pose nan = Pose::Identity();
  nan.translation().z() = std::nan("");
  EXPECT_NE(error_of([&] { tree.add("odom", "base_link", 1.0, nan, false); }).find("not finite"), std::string::npos);
  EXPECT_FALSE(tree.has_frame("lidar"));
  EXPECT_NO_THROW(tree.add("base_link", "lidar", 0.0, pose_from_xyz_rpy(999999, 0, 0, 0, 0, 0), true));
}

}  // namespace
}  // namespace tsdf_mcl
