// tf for the node core (transform_buffer.hpp): lookups at a stamp and at the latest time, a lookup that waits for a
// transform another thread sends (woken by it, not by a timer), time going back.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "transform_buffer.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::node {
namespace {

Stamp at(double s) { return Stamp::from_seconds(s); }

TEST(TransformBuffer, LooksUpAtAStampAndAtTheLatestTime) {
  TransformBuffer tf;
  tf.set("base_link", "lidar", at(0), pose_from_xyz_rpy(0, 0, 0.5, 0, 0, 0), true);
  tf.set("odom", "base_link", at(10), pose_from_xyz_rpy(0, 0, 0, 0, 0, 0), false);
  tf.set("odom", "base_link", at(11), pose_from_xyz_rpy(2, 0, 0, 0, 0, 0), false);
  const auto p = tf.lookup("odom", "lidar", at(10.5), 0.0);
  ASSERT_TRUE(p);
  EXPECT_NEAR(p->translation().x(), 1.0, 1e-9);
  EXPECT_NEAR(p->translation().z(), 0.5, 1e-9);
  const auto latest = tf.lookup("odom", "lidar", std::nullopt, 0.0);
  ASSERT_TRUE(latest);
  EXPECT_NEAR(latest->translation().x(), 2.0, 1e-9);
  std::string error;
  EXPECT_FALSE(tf.lookup("odom", "lidar", at(12), 0.0, &error));
  EXPECT_NE(error.find("not at 12 s"), std::string::npos) << error;
  EXPECT_FALSE(tf.lookup("odom", "camera", at(10.5), 0.0, &error));
  EXPECT_NE(error.find("'camera' is in no tf message"), std::string::npos) << error;
  // A child with a second parent contradicts the tree.
  EXPECT_THROW(tf.set("map", "base_link", at(11), Pose::Identity(), false), Error);
}

TEST(TransformBuffer, ALookupWaitsForTheTransformOnItsWay) {
  TransformBuffer tf;
  tf.set("odom", "base_link", at(1), Pose::Identity(), false);
  std::thread sender([&] {
    // Only once the lookup waits (it cannot succeed before this transform).
    std::this_thread::yield();
    tf.set("odom", "base_link", at(2), pose_from_xyz_rpy(1, 0, 0, 0, 0, 0), false);
  });
  const auto p = tf.lookup("odom", "base_link", at(2), 60.0);
  sender.join();
  ASSERT_TRUE(p);
  EXPECT_NEAR(p->translation().x(), 1.0, 1e-12);
}

TEST(TransformBuffer, TimeGoingBackKeepsTheStaticTransformsAndEndsWaits) {
  TransformBuffer tf;
  tf.set("base_link", "lidar", at(0), pose_from_xyz_rpy(0, 0, 0.5, 0, 0, 0), true);
  tf.set("odom", "base_link", at(100), Pose::Identity(), false);
  // A lookup waits for a stamp that never comes until a clear ends the wait (60 s would fail the suite's budget).
  // Cleared until the lookup returns: a clear before the wait began would not end it.
  std::atomic<bool> returned{false};
  std::thread clearer([&] {
    while (!returned) {
      tf.clear_moving();
      std::this_thread::yield();
    }
  });
  const auto start = std::chrono::steady_clock::now();
  tf.lookup("odom", "base_link", at(200), 60.0);
  returned = true;
  clearer.join();
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(30));
  EXPECT_FALSE(tf.can_lookup("odom", "base_link", at(100)));
  EXPECT_TRUE(tf.can_lookup("base_link", "lidar", std::nullopt));
  tf.set("odom", "base_link", at(5), Pose::Identity(), false);  // the new, earlier time
  EXPECT_TRUE(tf.can_lookup("odom", "lidar", at(5)));
}

}  // namespace
}  // namespace tsdf_mcl::node
