#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "ros_conversions.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"

namespace tsdf_mcl::ros_node {
namespace {

TEST(RosConversions, PoseRoundTrip) {
  Pose p = pose_from_xyz_rpy(1.0, -2.0, 0.5, 0.1, -0.2, 2.5);
  const Pose q = pose_from_msg(msg_from_pose(p));
  EXPECT_LT((q.matrix() - p.matrix()).norm(), 1e-12);
  const Pose r = pose_from_msg(transform_from_pose(p));
  EXPECT_LT((r.matrix() - p.matrix()).norm(), 1e-12);
}

TEST(RosConversions, ZeroQuaternionIsNoRotation) {
  geometry_msgs::Pose m;  // all zero: what a client that fills only the position sends
  m.position.x = 3.0;
  const Pose p = pose_from_msg(m);
  EXPECT_TRUE(p.rotation().isApprox(Eigen::Matrix3d::Identity()));
  EXPECT_DOUBLE_EQ(p.translation().x(), 3.0);
}

TEST(RosConversions, CovarianceRotationTurnsIntoTheFixedFrame) {
  // Rotation uncertainty about the body's x axis only; the body is yawed 90 degrees, so in the fixed frame the
  // uncertainty is about y.
  const Pose mean = pose_from_xyz_rpy(0, 0, 0, 0, 0, M_PI / 2);
  Matrix6d body = Matrix6d::Zero();
  body(0, 0) = 0.04;  // x position
  body(3, 3) = 0.01;  // rotation about body x
  const boost::array<double, 36> c = ros_covariance(mean, body);
  EXPECT_NEAR(c[0], 0.04, 1e-12);
  EXPECT_NEAR(c[3 * 6 + 3], 0.0, 1e-12);
  EXPECT_NEAR(c[4 * 6 + 4], 0.01, 1e-12);
}

TEST(RosConversions, CloudThroughTheCheckedDecoder) {
  PointCloud cloud;
  cloud.points = {{1, 2, 3}, {4, 5, 6}};
  cloud.intensity = {0.5f, 1.0f};
  sensor_msgs::PointCloud2 msg = msg_from_cloud(cloud);
  const PointCloud back = cloud_from_msg(msg, "test");
  ASSERT_EQ(back.points.size(), 2u);
  EXPECT_EQ(back.points[1], cloud.points[1]);
  msg.width = 1000;  // a size field that does not fit the data is an error, not a read past the end
  EXPECT_THROW(cloud_from_msg(msg, "test"), Error);
}

}  // namespace
}  // namespace tsdf_mcl::ros_node
