// Between ROS 1 messages and the node core's (ros_conversions.hpp): field by field, ROS 1's whole time range, a
// cloud's data kept alive by the message it came in.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "message_checks.hpp"
#include "ros_conversions.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/pointcloud2.hpp"

namespace tsdf_mcl::ros_node {
namespace {

TEST(RosConversions, PoseRoundTrip) {
  const Pose p = pose_from_xyz_rpy(1.0, -2.0, 0.5, 0.1, -0.2, 2.5);
  const Pose q = node::to_pose(raw_pose(msg_from_pose(p)));
  EXPECT_LT((q.matrix() - p.matrix()).norm(), 1e-12);
  const Pose r = node::to_pose(raw_pose(transform_from_pose(p)));
  EXPECT_LT((r.matrix() - p.matrix()).norm(), 1e-12);
}

TEST(RosConversions, Ros1TimeIsTakenWholeAndClampedOnTheWayOut) {
  const node::RawStamp past_2038 = raw_stamp(ros::Time(3000000000u, 5u));
  EXPECT_EQ(past_2038.sec, 3000000000LL);
  EXPECT_EQ(node::stamp_problem(past_2038), "");
  EXPECT_EQ(ros_time(node::to_stamp(past_2038)), ros::Time(3000000000u, 5u));
  // A map -> odom stamp past ROS 1's end (a scan's plus transform_tolerance) is its last nanosecond.
  EXPECT_EQ(ros_time(node::Stamp{4294967296LL * 1000000000LL}), ros::Time(4294967295u, 999999999u));
  EXPECT_EQ(ros_time(node::Stamp{-5}), ros::Time(0, 0));
}

TEST(RosConversions, CloudViewKeepsTheMessageAlive) {
  PointCloud cloud;
  cloud.points = {{1, 2, 3}, {4, 5, 6}};
  node::CloudOut out;
  out.cloud = encode_pointcloud2(cloud);
  out.frame_id = "lidar";
  node::CloudMsg view;
  {
    const sensor_msgs::PointCloud2ConstPtr msg(new sensor_msgs::PointCloud2(msg_from_cloud(out)));
    view = cloud_of(msg);
  }  // the test's pointer is gone; the view's owner keeps the message
  EXPECT_EQ(view.header.frame_id, "lidar");
  const PointCloud back = decode_pointcloud2(view.layout, view.data, view.size);
  ASSERT_EQ(back.points.size(), 2u);
  EXPECT_EQ(back.points[1], cloud.points[1]);
  view.layout.width = 1000;  // a size field that does not fit the data is an error, not a read past the end
  EXPECT_THROW(decode_pointcloud2(view.layout, view.data, view.size), Error);
}

}  // namespace
}  // namespace tsdf_mcl::ros_node
