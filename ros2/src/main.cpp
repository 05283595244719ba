// tsdf_mcl_ros2: 6-DoF Monte Carlo localization in a TSDF map as a ROS 2 node, over Cyclone DDS without ROS 2
// installed (ros2_node.hpp over the node core; docs/ros2.md).
#include <csignal>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "dds_domain.hpp"
#include "ros2_node.hpp"
#include "ros_arguments.hpp"
#include "tsdf_mcl/core/one_line.hpp"

namespace {

volatile std::sig_atomic_t g_stop = 0;

void on_signal(int) { g_stop = 1; }

const char* const kHelp =
    "usage: tsdf_mcl_ros2 --ros-args [-r __ns:=/NS] [-r __node:=NAME] [-r FROM:=TO] [--params-file FILE]\n"
    "                     [-p NAME:=VALUE ...]\n"
    "A ROS 2 node over DDS (Cyclone DDS, rmw_cyclonedds_cpp's conventions; no ROS 2 installation needed):\n"
    "localizes a LiDAR in a TSDF map from tsdf-mcl build-map and publishes amcl_pose, particle_cloud, tf map -> odom\n"
    "and /diagnostics as nav2 AMCL does. Parameters as `tsdf-mcl localize --help` names them, plus map_file "
    "(required),\n"
    "the frames, point_topics, odom_topic, imu_topic, last_pose_file, use_sim_time and cloud_reliability; a params\n"
    "file holds them under `tsdf_mcl: ros__parameters:`. The domain comes from ROS_DOMAIN_ID, ROS_LOCALHOST_ONLY or\n"
    "ROS_AUTOMATIC_DISCOVERY_RANGE and CYCLONEDDS_URI. See docs/ros2.md.\n";

}  // namespace

int main(int argc, char** argv) {
  try {
    const tsdf_mcl::ros2_node::RosArguments arguments =
        tsdf_mcl::ros2_node::parse_ros_arguments(std::vector<std::string>(argv + 1, argv + argc));
    if (arguments.help) {
      std::fputs(kHelp, stdout);
      return 0;
    }
    const tsdf_mcl::ros2_node::DomainConfig domain = tsdf_mcl::ros2_node::domain_from_environment();
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    tsdf_mcl::ros2_node::Ros2Node node(arguments, domain);
    node.run([] { return g_stop == 0; });
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tsdf_mcl_ros2: error: %s\n", tsdf_mcl::one_line(e.what()).c_str());
    return 1;
  }
  return 0;
}
