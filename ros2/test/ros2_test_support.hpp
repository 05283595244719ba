#pragma once
// What the ROS 2 node's tests share: a folder of the test's own, a params file, the node started as a ROS 2 node is
// (tsdf_mcl_ros2 --ros-args ...) in the test's domain, and a link to it that waits until the node is up.
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "dds_link.hpp"

namespace tsdf_mcl::ros2_node::test {

inline fs::path test_folder(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("tsdf_mcl_ros2_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A ROS 2 params file: `tsdf_mcl: ros__parameters:` with `lines` ("name: value"), and use_sim_time for every node.
inline fs::path params_file(const fs::path& dir, const std::vector<std::string>& lines, bool use_sim_time) {
  const fs::path file = dir / "params.yaml";
  std::ofstream out(file);
  out << "/**:\n  ros__parameters:\n    use_sim_time: " << (use_sim_time ? "true" : "false") << "\n";
  out << "tsdf_mcl:\n  ros__parameters:\n";
  for (const std::string& l : lines) out << "    " << l << "\n";
  return file;
}

inline std::vector<std::string> node_command(const std::vector<std::string>& ros_args) {
  std::vector<std::string> args = {TSDF_MCL_ROS2, "--ros-args"};
  args.insert(args.end(), ros_args.begin(), ros_args.end());
  return args;
}

// The node and the test's link to it, once the node's endpoints matched the link's.
struct RunningNode {
  RunningNode(const std::vector<std::string>& ros_args, const fs::path& log, double transform_tolerance = 0.1)
      : process(node_command(ros_args), log), link(process, transform_tolerance) {
    up = link.connected(std::chrono::seconds(120));
    if (!up) ADD_FAILURE() << "the node did not come up; see " << log;
  }
  node::test::Child process;
  DdsLink link;
  bool up = false;
};

}  // namespace tsdf_mcl::ros2_node::test
