#pragma once
// Scenarios a localization node is driven through in the tests, once for every transport (node_link.hpp): a dataset
// played scan by scan (each scan's odometry on tf, then the cloud, then the node's answer awaited: the node never
// skips a scan, so the outcome does not depend on the machine's load), and what it says about the run.
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "node_link.hpp"
#include "tsdf_mcl/io/dataset.hpp"

namespace tsdf_mcl::node::test {

namespace fs = std::filesystem;

struct Played {
  RawStamp stamp;
  Pose truth = Pose::Identity();  // world_T_base
  Pose odom_T_base = Pose::Identity();
  std::optional<Heard> heard;
  std::optional<TransformOut> map_odom;
};

struct PlayOptions {
  std::vector<std::size_t> scans;        // dataset indices, in order
  double time_offset = 0.0;              // s added to the dataset's times (a replay on a clock that went back)
  bool send_clock = false;               // /clock before each scan
  std::size_t stop_after_converged = 0;  // > 0: the play ends once the node said converged this many times
  std::string base_frame = "base_link", sensor_frame = "lidar", odom_frame = "odom";
};

// Sends the static base -> sensor transform (identity: the dataset's poses are the sensor's), then each scan:
// /clock, odom -> base at the scan's time (the dataset's odometry, else its ground truth), the cloud; and waits for
// the node's answer to it.
std::vector<Played> play(NodeLink& link, const Dataset& data, const PlayOptions& options);

struct Outcome {
  std::size_t scans = 0, answered = 0, converged = 0, false_claims = 0;
  std::optional<std::size_t> first_converged;           // position in the play
  double rmse_m = 0.0;                                  // converged scans' amcl_pose against the truth
  double max_tf_error_m = 0.0, max_tf_error_deg = 0.0;  // map -> odom ∘ odom -> base against the truth
  std::size_t tf_checked = 0;
  std::string first_state, last_state;
};
Outcome summarize(const std::vector<Played>& played);
std::string describe(const Outcome& o);

// The simulated office's test route (8 m, seed 2) as a dataset, `run/`, and its map from the same scans, `map.tsdf`:
// small and quick, enough for a node's plumbing. Built once per build of the tsdf-mcl program and shared by the node
// tests (a lock file holds the others until the first has built it); fails the test where the CLI does.
fs::path small_office();
// Runs the tsdf-mcl program; false (with the command in the failure) where it fails.
bool run_cli(const std::string& args, const fs::path& log);
RawStamp raw(double seconds);
double angle_deg(const Pose& a, const Pose& b);

}  // namespace tsdf_mcl::node::test
