// rosbag2 recordings written by other tools (tests/data/rosbag2/README.md): MCAP files from Foxglove's writer and
// ROS 2 serializer (chunks compressed with zstd and with lz4, and one without summary or index; /tf in big-endian
// CDR), and rosbag2's own SQLite3 and MCAP test recordings.
#include <gtest/gtest.h>

#include <string>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/bag_messages.hpp"
#include "tsdf_mcl/io/dataset.hpp"

namespace tsdf_mcl {
namespace {

namespace fs = std::filesystem;

fs::path data(const std::string& name) { return fs::path(test::test_data_dir()) / "rosbag2" / name; }

Pose xyz_yaw(double x, double y, double z, double yaw) {
  return msg::pose_of({x, y, z}, Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())));
}

std::string error_of(const fs::path& bag, const BagOptions& o) {
  try {
    Dataset::open_bag(bag, o);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// What make_foreign_bags.mjs wrote: 5 scans at 10 Hz from 100 s in frame velodyne, mounted 0.2 m ahead and 0.5 m
// up on base_link; odometry 0.1 m and 0.05 rad a scan; the truth 1 m ahead and 2 m aside of it in map.
TEST(Rosbag2Foreign, FoxgloveWrittenMcapsReadAsTheirRun) {
  for (const char* name : {"foreign_zstd.mcap", "foreign_lz4.mcap", "foreign_no_summary.mcap"}) {
    BagOptions o;
    o.points_topic = "/points";
    o.ground_truth_topic = "/ground_truth";
    o.imu_topic = "/imu";
    const Dataset ds = Dataset::open_bag(data(name), o);
    o.odom_topic = "/odom";
    const Dataset from_odom_topic = Dataset::open_bag(data(name), o);
    ASSERT_EQ(ds.size(), 5u) << name << ": " << ds.summary();
    const Pose base_T_velodyne = xyz_yaw(0.2, 0, 0.5, 0);
    for (std::size_t k = 0; k < 5; ++k) {
      EXPECT_EQ(ds.time(k), 100.0 + static_cast<double>(k * 100000000) / 1e9) << name;
      const Pose odometry = xyz_yaw(0.1 * k, 0, 0, 0.05 * k) * base_T_velodyne;
      const Pose truth = xyz_yaw(0.1 * k + 1, 2, 0, 0.05 * k) * base_T_velodyne;
      EXPECT_LT((ds.odometry(k).matrix() - odometry.matrix()).cwiseAbs().maxCoeff(), 1e-12) << name << " " << k;
      EXPECT_LT((from_odom_topic.odometry(k).matrix() - odometry.matrix()).cwiseAbs().maxCoeff(), 1e-12) << name;
      EXPECT_LT((ds.pose(k).matrix() - truth.matrix()).cwiseAbs().maxCoeff(), 1e-12) << name << " " << k;
      const PointCloud c = ds.load_scan(k);
      ASSERT_EQ(c.size(), 10u) << name;
      for (std::size_t i = 0; i < 10; ++i) {
        EXPECT_EQ(c.points[i], Eigen::Vector3f(static_cast<float>(k + i), 0.5f * i, 1.0f)) << name;
        EXPECT_EQ(c.intensity[i], static_cast<float>(i)) << name;
      }
    }
    EXPECT_EQ(ds.imu().size(), 10u) << name;
    EXPECT_EQ(ds.imu()[0].acceleration, Eigen::Vector3d(0, 0, 9.81)) << name;
    EXPECT_NE(ds.summary().find("odometry from tf 'odom' -> 'base_link'; ground truth from /ground_truth ('map' -> "
                                "'base_link'); 10 IMU samples from /imu"),
              std::string::npos)
        << ds.summary();
  }
}

// rosbag2's own recordings hold topics of types tsdf-mcl does not read: the topics and their types come out right.
TEST(Rosbag2Foreign, RosbagRecordedStoragesListTheirTopics) {
  for (const char* name : {"talker/talker.mcap", "talker/talker.db3"}) {
    BagOptions o;
    o.points_topic = "/points";
    EXPECT_NE(error_of(data(name), o)
                  .find("has no topic /points (the points topic); its sensor_msgs/msg/PointCloud2 topics: none"),
              std::string::npos)
        << error_of(data(name), o);
    o.points_topic = "/topic";
    EXPECT_NE(error_of(data(name), o)
                  .find("topic /topic (the points topic) carries std_msgs/msg/String, not sensor_msgs/msg/PointCloud2"),
              std::string::npos)
        << error_of(data(name), o);
    o.points_topic = "rosout";
    EXPECT_NE(error_of(data(name), o).find("topic /rosout (the points topic) carries rcl_interfaces/msg/Log"),
              std::string::npos)
        << error_of(data(name), o);
  }
}

}  // namespace
}  // namespace tsdf_mcl
