// tsdf_mcl_ros2 on the real balm_realworld sequence (../shared/data, skipped where absent) over DDS, as the suite's
// real-data tests run the CLI: the map from the even scans, the odd scans played with their noisy odometry on tf and
// the clock on /clock; the node localizes from nothing and its amcl_pose and tf map -> odom follow the sequence's
// poses.
#include <gtest/gtest.h>

#include "ros2_test_support.hpp"
#include "scenario.hpp"

namespace tsdf_mcl::ros2_node::test {
namespace {

TEST(Ros2RealData, LocalizesTheOddBalmScansOverDds) {
  const fs::path data_dir = fs::path(TSDF_MCL_SHARED_DATA) / "balm_realworld";
  if (!fs::exists(data_dir / "times.txt")) GTEST_SKIP() << "shared data " << data_dir << " not present";
  DomainClaim domain;
  const fs::path dir = test_folder("balm");
  ASSERT_TRUE(node::test::run_cli(
      "build-map --dataset '" + data_dir.string() + "' --stride 2 -o '" + (dir / "even.tsdf").string() + "'",
      dir / "cli.log"));
  const Dataset data = Dataset::open(data_dir);
  const fs::path params = params_file(dir,
                                      {"map_file: " + (dir / "even.tsdf").string(), "cloud_reliability: reliable",
                                       "seed: 1", "tf_timeout: 10.0", "last_pose_file: ''", "map_cloud_points: 1000",
                                       // What a person carrying the sensor knows (as RealData.BalmGlobal... gives
                                       // the CLI): level at the start, 1.2-1.8 m above the floor.
                                       "backend: cpu", "init_max_tilt: 0.05", "init_height_band: [1.2, 1.8]"},
                                      /*use_sim_time=*/true);
  RunningNode node({"--params-file", params.string()}, dir / "node.log");
  ASSERT_TRUE(node.up);
  node::test::PlayOptions o;
  for (std::size_t i = 1; i < data.size(); i += 2) o.scans.push_back(i);
  o.send_clock = true;
  const node::test::Outcome outcome = node::test::summarize(node::test::play(node.link, data, o));
  std::printf("ros2 node, balm odd scans: %s\n", node::test::describe(outcome).c_str());
  ASSERT_TRUE(outcome.first_converged) << node::test::describe(outcome);
  EXPECT_EQ(outcome.false_claims, 0u);
  EXPECT_LT(outcome.rmse_m, 0.10);
  EXPECT_GT(outcome.converged, 40u);
  EXPECT_GT(outcome.tf_checked, 40u);
  EXPECT_LT(outcome.max_tf_error_m, 0.3);
  EXPECT_LT(outcome.max_tf_error_deg, 3.0);
  EXPECT_EQ(outcome.last_state, "converged");
  node.process.stop();
  if (!HasFailure()) fs::remove_all(dir);
}

}  // namespace
}  // namespace tsdf_mcl::ros2_node::test
