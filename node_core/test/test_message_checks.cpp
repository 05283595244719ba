// The checks both nodes put every message through (message_checks.hpp): stamps of either ROS, poses whose
// quaternion is none, positions off the map.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "message_checks.hpp"

namespace tsdf_mcl::node {
namespace {

RawPose pose(double x, double y, double z, double qx, double qy, double qz, double qw) {
  RawPose p;
  p.position = {x, y, z};
  p.orientation = {qx, qy, qz, qw};
  return p;
}

TEST(MessageChecks, StampsOfBothRosVersionsAreUsable) {
  // ROS 1 time runs to 2^32 s: past 2^31 s (2038) and its last second are usable, and a difference across 2^31 s
  // stays exact.
  EXPECT_EQ(stamp_problem({2147483648LL, 0}), "");
  EXPECT_EQ(stamp_problem({4294967295LL, 999999999u}), "");
  const Stamp a = to_stamp({2147483647LL, 500000000u}), b = to_stamp({2147483649LL, 0u});
  EXPECT_DOUBLE_EQ(seconds_between(a, b), 1.5);
  EXPECT_EQ(to_stamp({4294967295LL, 999999999u}).ns, 4294967295999999999LL);
  // ROS 2's int32 seconds may be negative; rclcpp refuses such times, and so does the node.
  EXPECT_EQ(stamp_problem({-1, 0}), "negative stamp (-1 s)");
  EXPECT_EQ(stamp_problem({5, 1000000000u}), "stamp with 1000000000 nanoseconds (a second or more)");
  EXPECT_EQ(stamp_problem({4294967296LL, 0}), "stamp 4294967296 s is beyond 2^32 s");
}

TEST(MessageChecks, AQuaternionMustBeOne) {
  EXPECT_EQ(pose_problem(pose(1, 2, 3, 0, 0, std::sin(0.3), std::cos(0.3)), false), "");
  EXPECT_EQ(pose_problem(pose(0, 0, 0, 0, 0, 0, 1.004), false), "");  // within tf2's 1 % of the square
  // Its norm overflows a double: taken without overflow, it is far from 1, not a rotation (once taken as identity).
  EXPECT_EQ(pose_problem(pose(0, 0, 0, 1e200, 1e200, 0, 1e200), true),
            "quaternion (1e+200, 1e+200, 0, 1e+200) is not of unit length (norm 1.73205e+200)");
  EXPECT_NE(pose_problem(pose(0, 0, 0, 1e-200, 0, 0, 1e-200), true).find("not of unit length"), std::string::npos);
  EXPECT_NE(pose_problem(pose(0, 0, 0, 0, 0, 0, 1.2), true).find("not of unit length (norm 1.2)"), std::string::npos);
  // All zero: an odometry or initial pose message that filled in only the position; tf2 refuses it in a transform.
  EXPECT_EQ(pose_problem(pose(1, 0, 0, 0, 0, 0, 0), true), "");
  EXPECT_TRUE(to_pose(pose(1, 0, 0, 0, 0, 0, 0)).rotation().isApprox(Eigen::Matrix3d::Identity()));
  EXPECT_EQ(pose_problem(pose(1, 0, 0, 0, 0, 0, 0), false), "quaternion (0, 0, 0, 0) is no rotation");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(pose_problem(pose(0, 0, 0, nan, 0, 0, 1), true).find("non-finite pose"), std::string::npos);
  EXPECT_NE(pose_problem(pose(1e300, 0, 0, 0, 0, 0, 1), true).find("beyond 1e+06 m"), std::string::npos);
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_NE(pose_problem(pose(0, inf, 0, 0, 0, 0, 1), true).find("non-finite pose"), std::string::npos);
}

TEST(MessageChecks, APositionOffTheMapIsNamed) {
  // A map of 10 x 10 x 2 blocks of 8 voxels of 0.1 m: 0..8 m, 0..8 m, 0..1.6 m.
  const TsdfMap map(0.1f, 0.3f, Eigen::Vector3i(0, 0, 0), Eigen::Vector3i(10, 10, 2));
  EXPECT_EQ(outside_map_problem(map, {4, 4, 1}), "");
  EXPECT_EQ(outside_map_problem(map, {-0.9, 8.9, 2.5}), "");  // within the 1 m margin
  EXPECT_EQ(outside_map_problem(map, {9.9e5, -9.9e5, 0}),
            "position (990000.00, -990000.00, 0.00) m lies outside the map (x -0.1..7.9, y -0.1..7.9, z -0.1..1.6 m)");
  EXPECT_NE(outside_map_problem(map, {4, 4, -1.5}), "");
}

TEST(MessageChecks, ImuSpecificForce) {
  ImuMsg imu;
  imu.linear_acceleration = {0, 0, 9.81};
  EXPECT_EQ(imu_problem(imu), "");
  imu.linear_acceleration.x() = 2000;
  EXPECT_NE(imu_problem(imu).find("beyond 1000 m/s^2"), std::string::npos);
}

}  // namespace
}  // namespace tsdf_mcl::node
