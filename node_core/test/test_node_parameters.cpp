// The node's parameters as both nodes read them (node_parameters.hpp): frames that cannot work refused in one line,
// the schema's names, the mounting parameter, unknown names warned about, each named the way its transport names it.
#include <gtest/gtest.h>

#include <cstdlib>
#include <functional>

#include "node_parameters.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::node {
namespace {

using Type = ParameterValue::Type;

NodeParameters ros1(std::map<std::string, ParameterValue> values) {
  NodeParameters p;
  p.prefix = "~";
  p.separator = '/';
  p.values = std::move(values);
  p.values.emplace("map_file", ParameterValue{Type::kString, "map.tsdf"});
  return p;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(NodeParameters, FramesThatCannotWorkAreRefused) {
  const auto settings_error = [](std::map<std::string, ParameterValue> v) {
    return error_of([&] { settings_from(ros1(std::move(v)), ""); });
  };
  EXPECT_EQ(settings_error({{"global_frame_id", {Type::kString, ""}}}), "~global_frame_id is empty: name a tf frame");
  EXPECT_EQ(settings_error({{"base_frame_id", {Type::kString, "map"}}}),
            "~base_frame_id and ~global_frame_id are both 'map': the node estimates the one in the other");
  EXPECT_EQ(settings_error({{"odom_frame_id", {Type::kString, "base_link"}}}),
            "~odom_frame_id and ~base_frame_id are both 'base_link': odometry moves the base in the odometry frame");
  EXPECT_EQ(settings_error({{"odom_frame_id", {Type::kString, "map"}}}),
            "~odom_frame_id and ~global_frame_id are both 'map': the node publishes the one in the other on tf");
  EXPECT_EQ(settings_error({{"odom_frame_id", {Type::kString, ""}}}), "~odom_frame_id is empty: name a tf frame");
  EXPECT_EQ(settings_error({}), "");
  NodeParameters no_map;
  EXPECT_EQ(error_of([&] { settings_from(no_map, ""); }), "map_file is not set (a TSDF map from tsdf-mcl build-map)");
}

TEST(NodeParameters, OwnValuesAreChecked) {
  const NodeSettings s = settings_from(ros1({{"point_topics", {Type::kList, "/a,/b"}},
                                             {"transform_tolerance", {Type::kDouble, "0.25"}},
                                             {"tf_broadcast", {Type::kBool, "false"}},
                                             {"sensor_extrinsics.lidar", {Type::kList, "0,0,0.5,0,0,90deg"}},
                                             {"last_pose_file", {Type::kString, "/tmp/pose.json"}}}),
                                       "/default.json");
  EXPECT_EQ(s.point_topics, (std::vector<std::string>{"/a", "/b"}));
  EXPECT_DOUBLE_EQ(s.transform_tolerance, 0.25);
  EXPECT_FALSE(s.tf_broadcast);
  ASSERT_EQ(s.sensor_extrinsics.count("lidar"), 1u);
  EXPECT_NEAR(s.sensor_extrinsics.at("lidar").translation().z(), 0.5, 1e-12);
  EXPECT_NEAR(s.sensor_extrinsics.at("lidar").rotation()(1, 0), 1.0, 1e-12);  // 90 deg about z
  EXPECT_EQ(s.last_pose_file, "/tmp/pose.json");
  EXPECT_EQ(settings_from(ros1({}), "/default.json").last_pose_file, "/default.json");  // on by default
  EXPECT_EQ(settings_from(ros1({{"last_pose_file", {Type::kString, ""}}}), "/default.json").last_pose_file, "");

  const auto error = [](std::map<std::string, ParameterValue> v) {
    return error_of([&] { settings_from(ros1(std::move(v)), ""); });
  };
  EXPECT_EQ(error({{"transform_tolerance", {Type::kString, "abc"}}}),
            "~transform_tolerance must be a number in 0..60, got 'abc'");
  EXPECT_EQ(error({{"tf_broadcast", {Type::kString, "maybe"}}}), "~tf_broadcast must be true or false, got 'maybe'");
  EXPECT_EQ(error({{"sensor_extrinsics.lidar", {Type::kString, "0 0 500 0 0 0"}}}),
            "~sensor_extrinsics/lidar's z must be a number in -100..100 m, got '500'");
}

TEST(NodeParameters, TheLastPoseFileIsKeptInRosHomeByTheNodesName) {
  const char* home = std::getenv("HOME");
  const std::string saved_home = home ? home : "";
  setenv("ROS_HOME", "/robot/home", 1);
  EXPECT_EQ(default_last_pose_file("/tsdf_mcl"), "/robot/home/tsdf_mcl_last_pose.json");
  EXPECT_EQ(default_last_pose_file("/robot1/localizer"), "/robot/home/robot1_localizer_last_pose.json");
  unsetenv("ROS_HOME");
  setenv("HOME", "/home/robot", 1);
  EXPECT_EQ(default_last_pose_file("/tsdf_mcl"), "/home/robot/.ros/tsdf_mcl_last_pose.json");
  setenv("HOME", saved_home.c_str(), 1);
}

TEST(NodeParameters, FilterParametersGoThroughTheSchema) {
  EXPECT_EQ(localizer_options_of(ros1({{"max_beams", {Type::kInteger, "64"}}})).preprocessing.max_beams, 64u);
  EXPECT_EQ(error_of([] {
              localizer_options_of(ros1({{"pf_z", {Type::kString, "abc"}}}));
            }),
            "parameter ~pf_z expects a number, got 'abc'");
  NodeParameters ros2 = ros1({{"pf_z", {Type::kString, "abc"}}});
  ros2.prefix = "";
  ros2.separator = '.';
  EXPECT_EQ(error_of([&] { localizer_options_of(ros2); }), "parameter pf_z expects a number, got 'abc'");
}

TEST(NodeParameters, UnknownNamesAreWarnedAboutWithTheClosest) {
  const NodeParameters p = ros1({{"sigma_hitt", {Type::kDouble, "0.2"}},
                                 {"use_sim_time", {Type::kBool, "true"}},
                                 {"initial_pose.yaww", {Type::kDouble, "1"}},
                                 {"sensor_extrinsics.any_frame", {Type::kString, "0 0 0 0 0 0"}}});
  const std::vector<std::string> warnings = unknown_parameter_warnings(p, {"use_sim_time"});
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_EQ(warnings[0].rfind("unknown parameter ~initial_pose/yaww ignored (did you mean ~initial_pose/yaw,", 0), 0u)
      << warnings[0];
  EXPECT_EQ(warnings[1], "unknown parameter ~sigma_hitt ignored (did you mean ~sigma_hit?)");
}

}  // namespace
}  // namespace tsdf_mcl::node
