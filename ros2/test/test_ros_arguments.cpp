// The ROS 2 node's command line, names and domain as rcl and rmw_cyclonedds_cpp define them (ros_arguments.hpp,
// ros_names.hpp, dds_domain.hpp), without DDS traffic.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>

#include "dds_domain.hpp"
#include "ros_arguments.hpp"
#include "ros_names.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::ros2_node {
namespace {

namespace fs = std::filesystem;

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(RosNames, ResolvedAsRclDoes) {
  const NameResolver root({"tsdf_mcl", "/"}, {});
  EXPECT_EQ(root.resolve("points"), "/points");
  EXPECT_EQ(root.resolve("/tf"), "/tf");
  EXPECT_EQ(root.resolve("~/hypotheses"), "/tsdf_mcl/hypotheses");
  const NameResolver robot({"localizer", "/robot1"},
                           {{"", "points", "/os_cloud_node/points"}, {"other", "odom", "/x"}});
  EXPECT_EQ(robot.resolve("amcl_pose"), "/robot1/amcl_pose");
  EXPECT_EQ(robot.resolve("~/hypotheses"), "/robot1/localizer/hypotheses");
  EXPECT_EQ(robot.resolve("/diagnostics"), "/diagnostics");
  EXPECT_EQ(robot.resolve("points"), "/os_cloud_node/points");  // remapped
  EXPECT_EQ(robot.resolve("odom"), "/robot1/odom");             // a rule for another node
  EXPECT_EQ(dds_topic("/robot1/amcl_pose"), "rt/robot1/amcl_pose");
  EXPECT_EQ(dds_request_topic("/reinitialize_global_localization"), "rq/reinitialize_global_localizationRequest");
  EXPECT_EQ(dds_reply_topic("/reinitialize_global_localization"), "rr/reinitialize_global_localizationReply");
  EXPECT_NE(error_of([&] { root.resolve("bad//name"); }).find("the name 'bad//name' has the part ''"),
            std::string::npos);
  EXPECT_NE(topic_name_problem("2d_points"), "");
  EXPECT_NE(topic_name_problem("points/"), "");
  EXPECT_EQ(topic_name_problem("~"), "");
}

TEST(RosArguments, RemapsParametersAndParameterFiles) {
  const fs::path dir = fs::temp_directory_path() / ("tsdf_mcl_ros_args_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const fs::path file = dir / "params.yaml";
  std::ofstream(file) << "/**:\n  ros__parameters:\n    use_sim_time: true\n    sigma_hit: 0.3\n"
                         "robot1:\n  localizer:\n    ros__parameters:\n      sigma_hit: 0.2\n"
                         "      initial_pose:\n        x: 1.5\n      point_topics: [/a, /b]\n"
                         "other_node:\n  ros__parameters:\n    sigma_hit: 9.0\n";
  const RosArguments a =
      parse_ros_arguments({"--ros-args", "-r", "__ns:=/robot1", "-r", "__node:=localizer", "--params-file",
                           file.string(), "-p", "max_beams:=64", "-r", "points:=/lidar", "--log-level", "debug", "--"});
  EXPECT_EQ(a.node.fully_qualified(), "/robot1/localizer");
  ASSERT_EQ(a.remaps.size(), 1u);
  EXPECT_EQ(a.remaps[0].to, "/lidar");
  const auto& v = a.parameters.values;
  // The entry naming the node wins over the wildcard one; another node's is not this node's.
  EXPECT_EQ(v.at("sigma_hit").text, "0.2");
  EXPECT_EQ(v.at("sigma_hit").type, node::ParameterValue::Type::kDouble);
  EXPECT_EQ(v.at("use_sim_time").type, node::ParameterValue::Type::kBool);
  EXPECT_EQ(v.at("initial_pose.x").text, "1.5");
  EXPECT_EQ(v.at("point_topics").text, "/a,/b");
  EXPECT_EQ(v.at("max_beams").type, node::ParameterValue::Type::kInteger);
  EXPECT_EQ(a.notes.size(), 1u);  // --log-level: accepted, not used
  fs::remove_all(dir);

  EXPECT_TRUE(node_pattern_matches("/**", "/robot1/localizer"));
  EXPECT_TRUE(node_pattern_matches("/*/localizer", "/robot1/localizer"));
  EXPECT_FALSE(node_pattern_matches("/*/localizer", "/a/b/localizer"));
  EXPECT_TRUE(node_pattern_matches("/**/localizer", "/a/b/localizer"));
  EXPECT_TRUE(node_pattern_matches("tsdf_mcl", "/tsdf_mcl"));
  EXPECT_FALSE(node_pattern_matches("tsdf_mcl", "/robot1/tsdf_mcl"));

  EXPECT_EQ(error_of([] {
              parse_ros_arguments({"--ros-args", "-p", "novalue"});
            }),
            "-p expects name:=value, got 'novalue'");
  EXPECT_EQ(error_of([] { parse_ros_arguments({"--ros-args", "-r"}); }), "-r needs a value");
  EXPECT_EQ(error_of([] { parse_ros_arguments({"stray"}); }),
            "unknown argument 'stray' (ROS arguments follow --ros-args; --help)");
  EXPECT_NE(error_of([] {
              parse_ros_arguments({"--ros-args", "-r", "__node:=a/b"});
            }).find("not a node name"),
            std::string::npos);
}

TEST(RosArguments, ValuesAreTypedAsYamlReadsThem) {
  using Type = node::ParameterValue::Type;
  EXPECT_EQ(typed_value("42").type, Type::kInteger);
  EXPECT_EQ(typed_value("0.5").type, Type::kDouble);
  EXPECT_EQ(typed_value(".nan").text, "nan");
  EXPECT_EQ(typed_value("True").text, "true");
  EXPECT_EQ(typed_value("'0.5'").type, Type::kString);
  EXPECT_EQ(typed_value("'0.5'").text, "0.5");
  EXPECT_EQ(typed_value("[0, 0, 0.5, 0, 0, 90deg]").text, "0,0,0.5,0,0,90deg");
  EXPECT_EQ(typed_value("abc").type, Type::kString);
}

TEST(DdsDomain, FromTheEnvironmentAsRmwCycloneddsReadsIt) {
  const auto with = [](const std::vector<std::pair<const char*, const char*>>& env) {
    for (const char* name : {"ROS_DOMAIN_ID", "ROS_LOCALHOST_ONLY", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_STATIC_PEERS",
                             "CYCLONEDDS_URI"}) {
      unsetenv(name);
    }
    for (const auto& [name, value] : env) setenv(name, value, 1);
  };
  with({});
  DomainConfig c = domain_from_environment();
  EXPECT_EQ(c.id, 0u);
  EXPECT_EQ(c.xml, "");
  with({{"ROS_DOMAIN_ID", "42"}, {"ROS_LOCALHOST_ONLY", "1"}});
  c = domain_from_environment();
  EXPECT_EQ(c.id, 42u);
  EXPECT_NE(c.xml.find("<NetworkInterface address=\"127.0.0.1\"/>"), std::string::npos) << c.xml;
  EXPECT_NE(c.xml.find("<Peer address=\"localhost\"/>"), std::string::npos) << c.xml;
  EXPECT_EQ(c.described, "domain 42, localhost only");
  with({{"ROS_AUTOMATIC_DISCOVERY_RANGE", "SUBNET"},
        {"ROS_STATIC_PEERS", "10.0.0.2;robot.local"},
        {"CYCLONEDDS_URI", "file:///etc/cyclone.xml"}});
  c = domain_from_environment();
  EXPECT_EQ(c.xml,
            "<CycloneDDS><Domain><Discovery><Peers><Peer address=\"10.0.0.2\"/><Peer address=\"robot.local\"/>"
            "</Peers></Discovery></Domain></CycloneDDS>,file:///etc/cyclone.xml");
  with({{"ROS_DOMAIN_ID", "233"}});
  EXPECT_EQ(error_of([] { domain_from_environment(); }), "ROS_DOMAIN_ID must be a whole number in 0..232, got '233'");
  with({{"ROS_DOMAIN_ID", "-1"}});
  EXPECT_NE(error_of([] { domain_from_environment(); }), "");
  with({{"ROS_AUTOMATIC_DISCOVERY_RANGE", "EVERYWHERE"}});
  EXPECT_NE(error_of([] { domain_from_environment(); }).find("must be LOCALHOST, SUBNET, OFF or SYSTEM_DEFAULT"),
            std::string::npos);
  with({});
}

}  // namespace
}  // namespace tsdf_mcl::ros2_node
