// tsdf_mcl_ros2 as a ROS 2 robot runs it, over DDS on the loopback interface in a domain of the test's own, driven
// by a client built from ROS 2's message definitions (dds_link.hpp): a simulated run played scan by scan on sim time
// (amcl_pose right, tf map -> odom composing to the truth, diagnostics converged), nav2's relocalization service and
// the topic trigger, an RViz /initialpose, a replay with the clock going back, a restart from the last converged pose;
// the hostile messages every transport's tests send; bad starts. Every wait is on a DDS event (a sample, a matched
// endpoint), never a sleep.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "hostile_scenario.hpp"
#include "ros2_test_support.hpp"
#include "scenario.hpp"
#include "sensor_msgs.h"
#include "tf2_msgs.h"

namespace tsdf_mcl::ros2_node::test {
namespace {

using node::test::Heard;
using node::test::Played;
using node::test::PlayOptions;
using namespace std::chrono_literals;

// Where the played robot is: a scan of the run, and what the play adds to the run's times there.
struct Place {
  std::size_t scan = 0;
  double offset = 0.0;
};

// Plays the scan of `place` again and again, 0.1 s apart (a robot standing still), until `done` holds for the node's
// answer; that answer.
template <typename Done>
Heard stand_until(DdsLink& link, const Dataset& data, Place& place, Done done) {
  Heard h;
  for (int i = 0; i < 20; ++i) {
    place.offset += 0.1;
    PlayOptions o{{place.scan}, place.offset, true};
    const std::vector<Played> played = node::test::play(link, data, o);
    if (played.empty() || !played.front().heard) return h;
    h = *played.front().heard;
    if (done(h)) return h;
  }
  ADD_FAILURE() << "20 scans without the expected answer; last: " << h.status.message;
  return h;
}

TEST(Ros2Node, LocalizesASimulatedRunAndFollowsItsRequests) {
  DomainClaim domain;
  const fs::path dir = test_folder("run");
  const fs::path office = node::test::small_office();
  ASSERT_TRUE(fs::exists(office / "complete")) << "see " << office / "cli.log";
  const Dataset data = Dataset::open(office / "run");
  const fs::path params =
      params_file(dir,
                  {"map_file: " + (office / "map.tsdf").string(), "cloud_reliability: reliable", "backend: cpu",
                   "seed: 1", "tf_timeout: 10.0", "last_pose_file: " + (dir / "last_pose.json").string()},
                  /*use_sim_time=*/true);
  const std::vector<std::string> ros_args = {"--params-file", params.string(), "-p", "map_cloud_points:=1000"};
  std::vector<std::size_t> scans;
  for (std::size_t i = 0; i < data.size(); i += 2) scans.push_back(i);
  Place here;
  {
    RunningNode node(ros_args, dir / "node.log");
    ASSERT_TRUE(node.up);
    DdsLink& link = node.link;

    // 1. Global localization from nothing on sim time.
    node::test::Outcome o = node::test::summarize(node::test::play(link, data, {scans, 0.0, true}));
    std::printf("ros2 node, global: %s\n", node::test::describe(o).c_str());
    ASSERT_TRUE(o.first_converged) << node::test::describe(o);
    EXPECT_EQ(o.false_claims, 0u);
    EXPECT_LT(o.rmse_m, 0.1);
    EXPECT_GT(o.tf_checked, 5u);
    EXPECT_LT(o.max_tf_error_m, 0.2);
    EXPECT_LT(o.max_tf_error_deg, 3.0);
    EXPECT_EQ(o.last_state, "converged");

    // 2. nav2's reinitialize_global_localization, then the run played again: the clock goes back, the node restarts
    //    tf and the filter, and recovers.
    link.global_localization();
    node::test::PlayOptions replay{scans, 0.0, true};
    replay.stop_after_converged = 10;
    o = node::test::summarize(node::test::play(link, data, replay));
    std::printf("ros2 node, replayed after reinitialize_global_localization: %s\n", node::test::describe(o).c_str());
    ASSERT_TRUE(o.first_converged) << node::test::describe(o);
    EXPECT_NE(o.first_state, "converged");
    EXPECT_EQ(o.false_claims, 0u);
    here = {scans[o.scans - 1], 0.0};  // where the replay ended
    Heard h = stand_until(link, data, here, [](const Heard& x) { return x.status.message == "converged"; });
    EXPECT_EQ(h.count("time_jumps"), 1u);
    EXPECT_EQ(h.count("global_searches"), 1u);
    EXPECT_EQ(h.value("reason").rfind("every rival refuted; ", 0), 0u) << h.value("reason");

    // 3. The topic trigger: a global search from the next scan.
    link.trigger_global_localization();
    h = stand_until(link, data, here, [](const Heard& x) { return x.count("global_searches") == 2; });
    EXPECT_NE(h.status.message, "converged") << "the first scan of a global search claims convergence";

    // 4. RViz's 2D Pose Estimate at the route's start, x, y, yaw only (0.36 m and 4.6 deg off; z, roll and pitch come
    //    from the map), then the route again, the clock going on: the node tracks from the operator's pose.
    const Pose truth = data.pose(0);
    const double yaw = std::atan2(truth.rotation()(1, 0), truth.rotation()(0, 0)) + 0.08;
    node::InitialPoseMsg estimate;
    estimate.header.frame_id = "map";
    estimate.pose.position = {truth.translation().x() + 0.3, truth.translation().y() - 0.2, 0.0};
    estimate.pose.orientation = {0.0, 0.0, std::sin(yaw / 2), std::cos(yaw / 2)};
    link.initial_pose(estimate);
    node::test::PlayOptions again{scans, here.offset + data.time(here.scan) - data.time(0) + 0.1, true};
    again.stop_after_converged = 10;
    const std::vector<Played> played = node::test::play(link, data, again);
    const auto first = std::find_if(played.begin(), played.end(),
                                    [](const Played& p) { return p.heard && p.heard->count("initial_poses") == 1; });
    ASSERT_NE(first, played.end()) << "the /initialpose was not applied";
    ASSERT_TRUE(first->heard->pose);
    // Where the operator put the robot, carried by its motion to the scan it was applied at.
    Pose given = truth;
    given.translation().head<2>() += Eigen::Vector2d(0.3, -0.2);
    given.linear() = Eigen::AngleAxisd(0.08, Eigen::Vector3d::UnitZ()).toRotationMatrix() * truth.linear();
    const Pose carried = given * (truth.inverse() * first->truth);
    EXPECT_LT((first->heard->pose->pose.translation().head<2>() - carried.translation().head<2>()).norm(), 0.5);
    EXPECT_NEAR(first->heard->pose->pose.translation().z(), first->truth.translation().z(), 0.15);
    o = node::test::summarize(played);
    std::printf("ros2 node, after /initialpose: %s\n", node::test::describe(o).c_str());
    ASSERT_TRUE(o.first_converged);
    EXPECT_EQ(o.false_claims, 0u);
    EXPECT_EQ(o.last_state, "converged");
    here = {scans[o.scans - 1], again.time_offset};
  }

  // 5. A restart: the node starts at the last converged pose it kept, not with a global search.
  ASSERT_TRUE(fs::exists(dir / "last_pose.json"));
  RunningNode restarted(ros_args, dir / "node2.log");
  ASSERT_TRUE(restarted.up);
  here.offset += 1000.0;  // a restart later, where the robot stopped
  const Heard h = stand_until(restarted.link, data, here, [](const Heard& x) { return x.pose.has_value(); });
  ASSERT_TRUE(h.pose);
  EXPECT_LT((h.pose->pose.translation() - data.pose(here.scan).translation()).norm(), 0.3);
  EXPECT_EQ(h.count("global_searches"), 0u);
  restarted.process.stop();
  if (!HasFailure()) fs::remove_all(dir);
}

// Bad starts: one error line naming what is wrong, exit status 1.
void expect_bad_starts_refused(const fs::path& dir, const std::string& map) {
  struct BadStart {
    std::vector<std::string> args;
    std::string error;
  };
  const std::vector<BadStart> bad = {
      {{"-p", "map_file:=" + (dir / "missing.tsdf").string()}, "missing.tsdf"},
      {{"-p", map, "-p", "global_frame_id:=''"}, "error: global_frame_id is empty: name a tf frame"},
      {{"-p", map, "-p", "base_frame_id:=map"}, "error: base_frame_id and global_frame_id are both 'map'"},
      {{"-p", map, "-p", "odom_frame_id:=base_link"}, "error: odom_frame_id and base_frame_id are both 'base_link'"},
      {{"-p", map, "-p", "transform_tolerance:=abc"},
       "error: transform_tolerance must be a number in 0..60, got 'abc'"},
      {{"-p", map, "-p", "pf_z:=abc"}, "error: parameter pf_z expects a number, got 'abc'"},
      {{"-p", map, "-p", "cloud_reliability:=sometimes"}, "error: cloud_reliability must be best_effort or reliable"},
      {{"-p", map, "-p", "point_topics:=[bad//name]"}, "error: the name 'bad//name'"},
      {{"-p", map, "--params-file", (dir / "missing.yaml").string()}, "missing.yaml"},
      {{"-p", map, "--frobnicate"}, "error: unknown ROS argument '--frobnicate'"},
  };
  for (std::size_t i = 0; i < bad.size(); ++i) {
    const fs::path log = dir / ("bad" + std::to_string(i) + ".log");
    node::test::Child node(node_command(bad[i].args), log);
    EXPECT_EQ(node.wait_for(60s), 1) << bad[i].error;
    std::ifstream in(log);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find(bad[i].error), std::string::npos) << text;
    EXPECT_EQ(text.find("error:"), text.rfind("error:")) << "more than one error line: " << text;
  }
}

TEST(Ros2Node, SurvivesHostileMessagesAndRefusesBadStarts) {
  DomainClaim domain;
  const fs::path dir = test_folder("hostile");
  const fs::path office = node::test::small_office();
  ASSERT_TRUE(fs::exists(office / "complete")) << "see " << office / "cli.log";
  const std::string map = "map_file:=" + (office / "map.tsdf").string();
  expect_bad_starts_refused(dir, map);

  RunningNode node({"-p", map,
                    "-p", "point_topics:=[/points]",
                    "-p", "odom_topic:=/odom",
                    "-p", "imu_topic:=/imu",
                    "-p", "backend:=cpu",
                    "-p", "particles:=3000",
                    "-p", "seed:=1",
                    "-p", "last_pose_file:=''",
                    "-p", "cloud_reliability:=reliable",
                    "-p", "sensor_extrinsics.lidar_b:=[0, 0, 0.5, 0, 0, 90deg]"},
                   dir / "node.log");
  ASSERT_TRUE(node.up);
  node::test::run_hostile_scenario(node.link, {"sensor_extrinsics.lidar_b", "/odom", /*ros1_time=*/false});
  if (HasFatalFailure()) return;
  node.process.stop();
  if (!HasFailure()) fs::remove_all(dir);
}

// The shipped params file starts the node without a warning; the QoS a ROS 2 user's publishers bring match it:
// sensor data (best effort) clouds the node's default (best effort) subscription, a transient-local /tf_static
// publisher as tf2_ros's static broadcaster is, a late transient-local amcl_pose subscriber.
TEST(Ros2Node, TakesTheShippedParamsAndMatchesTheQosOfRos2Publishers) {
  DomainClaim domain;
  const fs::path dir = test_folder("qos");
  const fs::path office = node::test::small_office();
  ASSERT_TRUE(fs::exists(office / "complete")) << "see " << office / "cli.log";
  RunningNode node({"--params-file", TSDF_MCL_ROS2_PARAMS, "-p", "map_file:=" + (office / "map.tsdf").string(), "-p",
                    "last_pose_file:=''"},
                   dir / "node.log");
  ASSERT_TRUE(node.up);
  std::ifstream in(dir / "node.log");
  const std::string log((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(log.find("WARN"), std::string::npos) << log;
  const dds_entity_t pp = node.link.participant();
  const Writer best_effort(pp, sensor_msgs_msg_dds__PointCloud2__desc, "rt/points", sensor_data_qos());
  EXPECT_TRUE(wait_for_matched(pp, best_effort.handle(), 1, 60s));
  const Writer sensor_tf(pp, tf2_msgs_msg_dds__TFMessage__desc, "rt/tf_static", latched_qos(1));
  EXPECT_TRUE(wait_for_matched(pp, sensor_tf.handle(), 1, 60s));
  // amcl_pose is transient local: a subscriber that comes late still gets the last pose (none yet: matched only).
  const Reader late(pp, geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc, "rt/amcl_pose", latched_qos(1));
  EXPECT_TRUE(wait_for_matched(pp, late.handle(), 1, 60s));
  node.process.stop();
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace tsdf_mcl::ros2_node::test
