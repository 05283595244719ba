#pragma once
// What the ROS node tests share: child processes, the CLI, a ROS master of their own, and waiting on a condition.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <memory>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "child_process.hpp"
#include "free_port.hpp"

namespace tsdf_mcl::ros_node {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using node::test::Child;

inline void run_cli(const std::string& args, const fs::path& log) {
  const std::string cmd = std::string(TSDF_MCL_CLI) + " " + args + " >>'" + log.string() + "' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd << " failed; see " << log;
}

// Polls `done` (a connection count, a flag a callback set) until it holds or `timeout` passed. The bound only
// stops a broken run; nothing waits a fixed time.
template <typename F>
bool wait_until(F&& done, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(20ms);
  }
  return true;
}

// A master of our own on the loopback address (nothing else on the machine hears it), and this process as a ROS
// node on it (ros::init; the caller calls ros::start()).
class Master {
 public:
  explicit Master(const fs::path& dir) {
    const int port = free_loopback_port();
    const std::string master = "http://127.0.0.1:" + std::to_string(port);
    setenv("ROS_MASTER_URI", master.c_str(), 1);
    setenv("ROS_HOSTNAME", "127.0.0.1", 1);
    setenv("ROS_HOME", (dir / "ros").c_str(), 1);
    setenv("ROS_LOG_DIR", (dir / "ros").c_str(), 1);
    fs::create_directories(dir / "ros");
    process_ = std::make_unique<Child>(std::vector<std::string>{"rosmaster", "--core", "-p", std::to_string(port)},
                                       dir / "rosmaster.log");
    int argc = 1;
    char name[] = "tsdf_mcl_test";
    char* argv[] = {name, nullptr};
    ros::init(argc, argv, "tsdf_mcl_test", ros::init_options::NoSigintHandler | ros::init_options::AnonymousName);
    up_ = wait_until([] { return ros::master::check(); }, 60s);
  }
  ~Master() { stop(); }
  bool up() const { return up_; }
  void stop() {
    if (ros::isStarted()) ros::shutdown();
    process_.reset();
  }

 private:
  std::unique_ptr<Child> process_;
  bool up_ = false;
};

}  // namespace tsdf_mcl::ros_node
