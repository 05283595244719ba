// The node against what real robots and bags send it (node_core/test/hostile_scenario.hpp, which the ROS 2 node's
// tests and the core's run too): a missing extrinsic, messages out of order, NaN, absurd, off-map and non-unit poses,
// stamps past 2^31 s, time going back; and bad parameters, frames or a missing map at start. The test itself
// publishes the messages (no bag): each step waits for the node's /diagnostics on a scan, never a fixed time.
#include <gtest/gtest.h>
#include <ros/ros.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "hostile_scenario.hpp"
#include "node_test_support.hpp"
#include "ros1_link.hpp"

namespace tsdf_mcl::ros_node {
namespace {

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Starts the node with `params`; returns its exit status once it ended within 60 s (-1: still running).
int start_and_exit(const std::vector<std::string>& params, const fs::path& log) {
  // A name of its own: parameters stay on the master after a node ends.
  static int started = 0;
  std::vector<std::string> args = {TSDF_MCL_NODE, "__name:=tsdf_mcl_bad" + std::to_string(started++)};
  args.insert(args.end(), params.begin(), params.end());
  Child node(args, log);
  return node.wait_for(60s);
}

// Bad starts: one error naming what is wrong, exit status 1.
void expect_bad_starts_refused(const fs::path& dir, const std::string& map) {
  struct BadStart {
    std::vector<std::string> params;
    std::string error;
  };
  const std::vector<BadStart> bad = {
      {{"_map_file:=" + (dir / "missing.tsdf").string()}, "missing.tsdf"},
      {{map, "_transform_tolerance:=.nan"}, "~transform_tolerance must be a number in 0..60, got"},
      {{map, "_transform_tolerance:=abc"}, "~transform_tolerance must be a number in 0..60, got 'abc'"},
      {{map, "_map_cloud_points:=1000000000000"},
       "~map_cloud_points must be a whole number in 0..1e+08, got 1000000000000"},
      {{map, "_sensor_extrinsics/lidar:=0 0 0.5"},
       "~sensor_extrinsics/lidar must be x, y, z, roll, pitch, yaw (m, and radians or e.g. 90deg), got '0 0 0.5'"},
      {{map, "_sensor_extrinsics/lidar:=0 0 500 0 0 0"},
       "~sensor_extrinsics/lidar's z must be a number in -100..100 m, got '500'"},
      {{map, "_sensor_extrinsics/lidar:=0 0 0.5 0 0 90"}, "~sensor_extrinsics/lidar's yaw 90 is more than"},
      {{map, "_global_frame_id:="}, "~global_frame_id is empty: name a tf frame"},
      {{map, "_base_frame_id:=map"}, "~base_frame_id and ~global_frame_id are both 'map'"},
      {{map, "_odom_frame_id:=base_link"}, "~odom_frame_id and ~base_frame_id are both 'base_link'"},
  };
  for (std::size_t i = 0; i < bad.size(); ++i) {
    const fs::path node_log = dir / ("bad" + std::to_string(i) + ".log");
    EXPECT_EQ(start_and_exit(bad[i].params, node_log), 1) << bad[i].error;
    const std::string text = read_text(node_log);
    EXPECT_NE(text.find(bad[i].error), std::string::npos) << text;
  }
}

TEST(RosNode, SurvivesHostileMessagesAndRefusesBadStarts) {
  const fs::path dir = fs::temp_directory_path() / ("tsdf_mcl_ros_hostile_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path log = dir / "cli.log";
  // A small map: 6 m of the office's test route.
  run_cli("simulate --scene office --lidar vlp16 --route test --seed 2 --length 6 -o '" + (dir / "run").string() + "'",
          log);
  run_cli("build-map --dataset '" + (dir / "run").string() + "' -o '" + (dir / "map.tsdf").string() + "'", log);
  if (HasFatalFailure()) return;
  const std::string map = "_map_file:=" + (dir / "map.tsdf").string();

  Master rosmaster(dir);
  ASSERT_TRUE(rosmaster.up()) << "rosmaster did not start; see " << dir / "rosmaster.log";
  ros::start();
  expect_bad_starts_refused(dir, map);

  ros::NodeHandle nh;
  ros::AsyncSpinner spinner(2);
  spinner.start();
  Child node({TSDF_MCL_NODE, "__name:=tsdf_mcl", map, "_point_topics:=/points", "_odom_topic:=/odom",
              "_imu_topic:=/imu", "_backend:=cpu", "_particles:=3000", "_seed:=1", "_last_pose_file:=",
              // The mounting of a second LiDAR frame that no tf knows (as roscpp passes it: text).
              "_sensor_extrinsics/lidar_b:=[0, 0, 0.5, 0, 0, 90deg]"},
             dir / "node.log");
  Ros1Link link(nh, node, 0.1);
  ASSERT_TRUE(ros::service::waitForService("/global_localization", ros::Duration(120.0)))
      << "the node did not come up; see " << dir / "node.log";
  ASSERT_TRUE(link.connected(60s));
  node::test::run_hostile_scenario(link, {"~sensor_extrinsics/lidar_b", "/odom", /*ros1_time=*/true});
  if (HasFatalFailure()) return;
  node.stop();
  rosmaster.stop();
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace tsdf_mcl::ros_node
