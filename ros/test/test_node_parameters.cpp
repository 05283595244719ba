// The node's parameters go through the library's schema (tsdf_mcl/localizer/localizer_parameters.hpp): a bad value
// stops it with one message naming the parameter, ROS 1 amcl's names are aliases, a misspelt name is warned about with
// the closest known one. Each case starts the node against a master of its own and waits for it to exit (the map file
// does not exist, so a node whose parameters pass stops at the map instead).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "free_port.hpp"

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    const std::string redirect = log.string();
    if (!freopen(redirect.c_str(), "w", stdout) || !freopen(redirect.c_str(), "a", stderr)) _exit(126);
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

// The exit status once the process ended within `timeout`, else -1 (then it is killed).
int wait_exit(pid_t pid, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    int status = 0;
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    std::this_thread::sleep_for(50ms);
  }
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  return -1;
}

std::string read_all(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

class NodeParameters : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("tsdf_mcl_ros_parameters_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "ros");
    const int port = tsdf_mcl::ros_node::free_loopback_port();
    setenv("ROS_MASTER_URI", ("http://127.0.0.1:" + std::to_string(port)).c_str(), 1);
    setenv("ROS_HOSTNAME", "127.0.0.1", 1);
    setenv("ROS_HOME", (dir_ / "ros").c_str(), 1);
    setenv("ROS_LOG_DIR", (dir_ / "ros").c_str(), 1);
    master_ = spawn({"rosmaster", "--core", "-p", std::to_string(port)}, dir_ / "rosmaster.log");
  }
  void TearDown() override {
    kill(master_, SIGINT);
    if (wait_exit(master_, 10s) < 0) ADD_FAILURE() << "rosmaster did not stop";
    fs::remove_all(dir_);
  }
  // Runs the node with `params` (":=" pairs) under a fresh name; its exit status and log.
  std::pair<int, std::string> run_node(const std::vector<std::string>& params) {
    const std::string name = "tsdf_mcl_" + std::to_string(++runs_);
    std::vector<std::string> args = {TSDF_MCL_NODE, "__name:=" + name,
                                     "_map_file:=" + (dir_ / "missing.tsdf").string()};
    args.insert(args.end(), params.begin(), params.end());
    const fs::path log = dir_ / (name + ".log");
    const int status = wait_exit(spawn(args, log), 60s);
    return {status, read_all(log)};
  }

  fs::path dir_;
  pid_t master_ = -1;
  int runs_ = 0;
};

TEST_F(NodeParameters, BadValuesStopTheNodeNamingTheParameter) {
  auto [status, log] = run_node({"_pf_z:=abc"});
  EXPECT_EQ(status, 1) << log;
  EXPECT_NE(log.find("parameter ~pf_z expects a number, got 'abc'"), std::string::npos) << log;

  std::tie(status, log) = run_node({"_initial_pose/yaw:=90"});
  EXPECT_EQ(status, 1) << log;
  EXPECT_NE(log.find("initial_pose.yaw 90 is more than"), std::string::npos) << log;
  EXPECT_NE(log.find("write 90deg"), std::string::npos) << log;

  std::tie(status, log) = run_node({"_kld_z:=2.0", "_pf_z:=3.0"});
  EXPECT_EQ(status, 1) << log;
  EXPECT_NE(log.find("kld_z is amcl's name of pf_z"), std::string::npos) << log;
}

TEST_F(NodeParameters, AmclAliasesPassAndTyposAreWarnedAbout) {
  const auto [status, log] =
      run_node({"_laser_max_beams:=64", "_odom_model_type:=diff", "_odom_alpha1:=0.3", "_sigma_hitt:=0.2"});
  EXPECT_EQ(status, 1) << log;
  EXPECT_EQ(log.find("tsdf_mcl: parameter ~"), std::string::npos) << "the aliases are accepted: " << log;
  EXPECT_NE(log.find("missing.tsdf"), std::string::npos) << "it stops at the map: " << log;
  EXPECT_NE(log.find("sigma_hitt ignored (did you mean ~sigma_hit?)"), std::string::npos) << log;
}

}  // namespace
