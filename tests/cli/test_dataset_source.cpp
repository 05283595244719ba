// Bags on the command line: simulate --bag writes one (ROS 1, or rosbag2 MCAP and SQLite3), localize / build-map /
// evaluate --bag read it, and a bag gives what the folder dataset of the same run gives.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "map_test_helpers.hpp"
#include "tsdf_mcl/io/dataset.hpp"

#if TSDF_MCL_HAVE_ROSBAG
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>
#endif

namespace tsdf_mcl {
namespace {

using test::CliResult;
using test::expect_one_line_error;
using test::run_cli;
using test::TempDir;

// The localize command of the bag tests: a small filter from the run's first true pose.
std::string localize_command(const std::string& folder, const std::string& map) {
  const Dataset d = Dataset::open(folder);
  const Pose& p0 = d.pose(0);
  const Eigen::Vector3d rpy = rpy_of(p0.linear());
  char init[200];
  std::snprintf(init, sizeof(init), " --init %.6f,%.6f,%.6f,%.6f,%.6f,%.6f", p0.translation().x(), p0.translation().y(),
                p0.translation().z(), rpy.x(), rpy.y(), rpy.z());
  return "localize --map " + map + init +
         " --backend cpu --seed 5 --particles 500 --min_particles 200 --max_particles 1000 --max_beams 128 --count 25";
}

#if TSDF_MCL_HAVE_ROSBAG

// One short simulated run, written as a folder and as a bag, and a map of it.
struct SimulatedRun {
  TempDir dir;
  std::string folder, bag, map;
  CliResult simulate;
  SimulatedRun() {
    folder = (dir / "run").string();
    bag = (dir / "run.bag").string();
    map = (dir / "run.tsdf").string();
    simulate = run_cli(
        dir, "simulate --scene office --lidar vlp16 --route test --seed 2 --length 1.5 --bag " + bag + " -o " + folder);
    if (simulate.exit_code == 0) run_cli(dir, "build-map --dataset " + folder + " --voxel 0.2 -o " + map);
  }
};

const SimulatedRun& simulated_run() {
  static const SimulatedRun r;
  return r;
}

const std::string kBagTopics = " --points /points --ground_truth_topic /ground_truth";

TEST(CliBag, SimulatedBagReadsBackAsTheFolderDataset) {
  const SimulatedRun& r = simulated_run();
  ASSERT_EQ(r.simulate.exit_code, 0) << r.simulate.err;
  EXPECT_NE(r.simulate.err.find("wrote " + r.bag), std::string::npos) << r.simulate.err;
  EXPECT_FALSE(std::filesystem::exists(r.bag + ".partial"));
  const Dataset folder = Dataset::open(r.folder);
  BagOptions options;
  options.points_topic = "/points";
  options.ground_truth_topic = "/ground_truth";
  const Dataset bag = Dataset::open_bag(r.bag, options);
  ASSERT_GT(folder.size(), 20u);
  ASSERT_EQ(bag.size(), folder.size()) << bag.summary();
  ASSERT_TRUE(bag.has_odometry() && bag.has_poses());
  options.odom_topic = "/odom";
  const Dataset odom_topic = Dataset::open_bag(r.bag, options);
  for (std::size_t i = 0; i < folder.size(); ++i) {
    EXPECT_NEAR(bag.time(i), folder.time(i), 1e-9);
    const PointCloud a = folder.load_scan(i), b = bag.load_scan(i);
    ASSERT_EQ(a.points, b.points) << i;
    EXPECT_EQ(a.intensity, b.intensity) << i;
    // poses.txt and odom.txt carry 9 decimals; the bag the doubles.
    EXPECT_LT((bag.odometry(i).matrix() - folder.odometry(i).matrix()).cwiseAbs().maxCoeff(), 1e-8) << i;
    EXPECT_LT((odom_topic.odometry(i).matrix() - folder.odometry(i).matrix()).cwiseAbs().maxCoeff(), 1e-8) << i;
    EXPECT_LT((bag.pose(i).matrix() - folder.pose(i).matrix()).cwiseAbs().maxCoeff(), 1e-8) << i;
  }

  // What ROS's own message classes see: the topics, types, frames and fields docs/bags.md promises.
  rosbag::Bag b(r.bag, rosbag::bagmode::Read);
  rosbag::View view(b);
  std::map<std::string, std::string> types;
  std::map<std::string, std::string> latching;  // what `rosbag play` reads to latch a topic again
  for (const rosbag::ConnectionInfo* c : view.getConnections()) {
    types[c->topic] = c->datatype;
    const auto it = c->header ? c->header->find("latching") : decltype(c->header->end()){};
    latching[c->topic] = c->header && it != c->header->end() ? it->second : "";
  }
  EXPECT_EQ(latching["/tf_static"], "1");
  EXPECT_NE(latching["/points"], "1");
  EXPECT_NE(latching["/tf"], "1");
  EXPECT_EQ(types, (std::map<std::string, std::string>{{"/points", "sensor_msgs/PointCloud2"},
                                                       {"/tf", "tf2_msgs/TFMessage"},
                                                       {"/tf_static", "tf2_msgs/TFMessage"},
                                                       {"/odom", "nav_msgs/Odometry"},
                                                       {"/ground_truth", "nav_msgs/Odometry"}}));
  bool cloud = false, statics = false, truth = false;
  for (const rosbag::MessageInstance& m : view) {
    if (auto pc = m.instantiate<sensor_msgs::PointCloud2>(); pc && !cloud) {
      cloud = true;
      EXPECT_EQ(pc->header.frame_id, "lidar");
      std::string names;
      for (const auto& f : pc->fields) names += f.name + " ";
      EXPECT_EQ(names, "x y z intensity ring ");
      EXPECT_EQ(pc->header.stamp.toSec(), m.getTime().toSec());
    }
    if (auto tf = m.instantiate<tf2_msgs::TFMessage>(); tf && m.getTopic() == "/tf_static") {
      statics = true;
      EXPECT_TRUE(m.isLatching());
      ASSERT_EQ(tf->transforms.size(), 1u);
      EXPECT_EQ(tf->transforms[0].header.frame_id, "base_link");
      EXPECT_EQ(tf->transforms[0].child_frame_id, "lidar");
      EXPECT_NEAR(tf->transforms[0].transform.translation.z, 0.5, 1e-12);  // the ground robot's sensor height
    }
    if (auto gt = m.instantiate<nav_msgs::Odometry>(); gt && m.getTopic() == "/ground_truth" && !truth) {
      truth = true;
      EXPECT_EQ(gt->header.frame_id, "map");
      EXPECT_EQ(gt->child_frame_id, "base_link");
    }
  }
  EXPECT_TRUE(cloud && statics && truth);
}

// The same run, seed and backend: the same trajectory from the bag as from the folder; evaluate and build-map read
// the bag's ground truth.
TEST(CliBag, LocalizeEvaluateAndBuildMapFromTheBag) {
  const SimulatedRun& r = simulated_run();
  ASSERT_EQ(r.simulate.exit_code, 0) << r.simulate.err;
  ASSERT_TRUE(std::filesystem::exists(r.map));
  TempDir out;
  const std::string common = localize_command(r.folder, r.map);
  const CliResult from_folder = run_cli(out, common + " --dataset " + r.folder + " -o " + (out / "dir").string());
  ASSERT_EQ(from_folder.exit_code, 0) << from_folder.err;
  const CliResult from_bag = run_cli(out, common + " --bag " + r.bag + " --points points -o " + (out / "bag").string());
  ASSERT_EQ(from_bag.exit_code, 0) << from_bag.err;
  EXPECT_NE(from_bag.err.find("localize: bag " + r.bag + ": "), std::string::npos) << from_bag.err;
  EXPECT_NE(from_bag.err.find("odometry from tf 'odom' -> 'base_link'"), std::string::npos) << from_bag.err;
  // The same estimates at the same times; the folder's odometry went through 9-decimal text, the bag's did not, so
  // the numbers agree to about 1e-8, up to the last (6th) decimal of the TUM lines.
  const std::vector<StampedPose> tum_folder = read_tum(out / "dir/trajectory.tum");
  const std::vector<StampedPose> tum_bag = read_tum(out / "bag/trajectory.tum");
  ASSERT_EQ(tum_folder.size(), 25u);
  ASSERT_EQ(tum_bag.size(), tum_folder.size());
  for (std::size_t i = 0; i < tum_folder.size(); ++i) {
    EXPECT_EQ(tum_bag[i].time, tum_folder[i].time) << i;
    EXPECT_LT((tum_bag[i].pose.matrix() - tum_folder[i].pose.matrix()).cwiseAbs().maxCoeff(), 1e-5)
        << i;  // TUM: 6 decimals
  }

  const CliResult eval_folder =
      run_cli(out, "evaluate --estimate " + (out / "dir/trajectory.tum").string() + " --dataset " + r.folder);
  const CliResult eval_bag =
      run_cli(out, "evaluate --estimate " + (out / "bag/trajectory.tum").string() + " --bag " + r.bag + kBagTopics);
  ASSERT_EQ(eval_bag.exit_code, 0) << eval_bag.err;
  const auto jf = nlohmann::json::parse(eval_folder.out), jb = nlohmann::json::parse(eval_bag.out);
  EXPECT_EQ(jb["scans"], jf["scans"]);
  EXPECT_EQ(jb["converged"], jf["converged"]);
  EXPECT_NEAR(jb["localized_fraction"].get<double>(), jf["localized_fraction"].get<double>(), 1e-12);

  const std::string bag_map = (out / "bag.tsdf").string();
  const CliResult built = run_cli(out, "build-map --bag " + r.bag + kBagTopics + " --voxel 0.2 -o " + bag_map);
  ASSERT_EQ(built.exit_code, 0) << built.err;
  const CliResult info_bag = run_cli(out, "info --json " + bag_map), info_folder = run_cli(out, "info --json " + r.map);
  ASSERT_EQ(info_bag.exit_code, 0) << info_bag.err;
  const auto ib = nlohmann::json::parse(info_bag.out), inf = nlohmann::json::parse(info_folder.out);
  // The same scans at poses equal to 1e-9: the same map, up to voxels on the edge of a decision.
  EXPECT_EQ(ib["allocated_blocks"], inf["allocated_blocks"]) << info_bag.out << "\n" << info_folder.out;
  EXPECT_NEAR(ib["known_voxels"].get<double>(), inf["known_voxels"].get<double>(),
              1e-3 * inf["known_voxels"].get<double>());

  // A given trajectory instead of the ground truth: localize's estimate, covering the first 25 scans.
  const CliResult from_trajectory =
      run_cli(out, "build-map --bag " + r.bag + " --points /points --trajectory " +
                       (out / "bag/trajectory.tum").string() + " --voxel 0.2 -o " + (out / "traj.tsdf").string());
  ASSERT_EQ(from_trajectory.exit_code, 0) << from_trajectory.err;
  EXPECT_NE(from_trajectory.err.find("lie outside the times of"), std::string::npos) << from_trajectory.err;
}

TEST(CliBag, BadInputFailsWithOneClearLine) {
  const SimulatedRun& r = simulated_run();
  ASSERT_EQ(r.simulate.exit_code, 0) << r.simulate.err;
  TempDir dir;
  test::write_bytes(dir / "text.bag", "not a bag at all");
  const std::string o = " -o " + (dir / "out").string();
  const std::string localize = "localize --map " + r.map + " --backend cpu";
  expect_one_line_error(dir, localize + " --bag " + r.bag + o, "--bag needs --points TOPIC");
  expect_one_line_error(
      dir, localize + " --bag " + r.bag + " --points /velodyne_points" + o,
      "has no topic /velodyne_points (the points topic); its sensor_msgs/PointCloud2 topics: /points");
  expect_one_line_error(dir, localize + " --bag " + r.bag + " --points /odom" + o,
                        "topic /odom (the points topic) carries nav_msgs/Odometry, not sensor_msgs/PointCloud2");
  expect_one_line_error(dir, localize + " --dataset " + r.folder + " --bag " + r.bag + " --points /points" + o,
                        "not both");
  expect_one_line_error(dir, localize + " --dataset " + r.folder + " --points /points" + o,
                        "--points applies to --bag only");
  expect_one_line_error(dir, localize + " --bag " + (dir / "text.bag").string() + " --points /points" + o,
                        "is not a bag: neither a ROS 1 bag");
  expect_one_line_error(dir, localize + " --bag " + r.bag + " --points /points --odom_frame wheel_odom" + o,
                        "has no odometry: no tf frame 'wheel_odom' (--odom_frame) and no --odom_topic, which "
                        "motion_model odometry needs");
  expect_one_line_error(dir, localize + " --bag " + r.bag + " --points /points --base_frame chassis" + o,
                        "no tf connects 'odom' and 'chassis'");
  expect_one_line_error(dir,
                        "evaluate --estimate " + (dir / "x.tum").string() + " --bag " + r.bag + " --points /points",
                        "has no ground truth (--ground_truth_topic)");
  expect_one_line_error(dir, "build-map --bag " + r.bag + " --points /points -o " + (dir / "m.tsdf").string(),
                        "or give --trajectory FILE.tum");
  expect_one_line_error(dir, "simulate --length 1 --bag " + (dir / "no/such/dir/run.bag").string() + o, "run.bag");
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
  // --help lists the bag options.
  const CliResult help = run_cli(dir, "localize --help");
  for (const char* option :
       {"--bag FILE", "--points TOPIC", "--odom_frame FRAME", "[default: odom]", "--base_frame FRAME",
        "[default: base_link]", "--odom_topic TOPIC", "--imu_topic TOPIC", "--ground_truth_topic TOPIC"}) {
    EXPECT_NE(help.out.find(option), std::string::npos) << option;
  }
}

#else

TEST(CliBag, BuiltWithoutBagSupportSaysSo) {
  TempDir dir;
  test::write_bytes(dir / "run.bag", "#ROSBAG V2.0\n" + std::string(5000, '\0'));
  expect_one_line_error(dir, "localize --map m.tsdf --bag run.bag --points /points -o out",
                        "built without ROS 1 bag support");
  expect_one_line_error(dir, "simulate --length 1 --bag new.bag -o " + (dir / "out").string(),
                        "built without ROS 1 bag support");
}

#endif

// The run of SimulatedRun above (seed 2, 1.5 m) as rosbag2 recordings: one MCAP file beside the folder, and one
// SQLite3 file written by another simulate of the same seed.
struct Ros2Run {
  TempDir dir;
  std::string folder, mcap, db3, map;
  CliResult simulate, simulate_db3;
  Ros2Run() {
    folder = (dir / "run").string();
    mcap = (dir / "run.mcap").string();
    db3 = (dir / "run.db3").string();
    map = (dir / "run.tsdf").string();
    const std::string sim = "simulate --scene office --lidar vlp16 --route test --seed 2 --length 1.5 --bag ";
    simulate = run_cli(dir, sim + mcap + " -o " + folder);
    simulate_db3 = run_cli(dir, sim + db3 + " -o " + (dir / "run_db3").string());
    if (simulate.exit_code == 0) run_cli(dir, "build-map --dataset " + folder + " --voxel 0.2 -o " + map);
  }
};

const Ros2Run& ros2_run() {
  static const Ros2Run r;
  return r;
}

// The done-when of ROS 2 bags: a run written as MCAP and as SQLite3 localizes exactly as its ROS 1 bag does (byte for
// byte the same trajectory), and as its folder does (to the folder's 9 decimals).
TEST(CliBag, Ros2BagsLocalizeAsTheRos1BagAndTheFolder) {
  const Ros2Run& r = ros2_run();
  ASSERT_EQ(r.simulate.exit_code, 0) << r.simulate.err;
  ASSERT_EQ(r.simulate_db3.exit_code, 0) << r.simulate_db3.err;
  EXPECT_NE(r.simulate.err.find("wrote " + r.mcap), std::string::npos) << r.simulate.err;
  TempDir out;
  const std::string common = localize_command(r.folder, r.map);
  std::vector<std::string> bags = {r.mcap, r.db3};
#if TSDF_MCL_HAVE_ROSBAG
  ASSERT_EQ(simulated_run().simulate.exit_code, 0) << simulated_run().simulate.err;
  bags.insert(bags.begin(), simulated_run().bag);
#endif
  std::vector<std::string> trajectories;
  for (std::size_t i = 0; i < bags.size(); ++i) {
    const std::string o = (out / ("out" + std::to_string(i))).string();
    const CliResult c = run_cli(out, common + " --bag " + bags[i] + " --points /points -o " + o);
    ASSERT_EQ(c.exit_code, 0) << bags[i] << ": " << c.err;
    EXPECT_NE(c.err.find("localize: bag " + bags[i] +
                         ": 56 scans on /points (frame 'lidar', 0.050..2.800 s); "
                         "odometry from tf 'odom' -> 'base_link'"),
              std::string::npos)
        << c.err;
    trajectories.push_back(test::read_bytes(o + "/trajectory.tum"));
    EXPECT_EQ(trajectories.back(), trajectories.front()) << bags[i] << " localizes otherwise than " << bags[0];
  }
  const CliResult from_folder = run_cli(out, common + " --dataset " + r.folder + " -o " + (out / "dir").string());
  ASSERT_EQ(from_folder.exit_code, 0) << from_folder.err;
  const std::vector<StampedPose> folder = read_tum(out / "dir/trajectory.tum");
  const std::vector<StampedPose> bag = read_tum(out / "out0/trajectory.tum");
  ASSERT_EQ(bag.size(), 25u);
  ASSERT_EQ(folder.size(), bag.size());
  for (std::size_t i = 0; i < bag.size(); ++i) {
    EXPECT_EQ(bag[i].time, folder[i].time);
    EXPECT_LT((bag[i].pose.matrix() - folder[i].pose.matrix()).cwiseAbs().maxCoeff(), 1e-5) << i;
  }

  // evaluate and build-map read the ground truth of a rosbag2 bag too.
  const CliResult eval = run_cli(out, "evaluate --estimate " + (out / "out1/trajectory.tum").string() + " --bag " +
                                          r.db3 + " --points /points --ground_truth_topic /ground_truth");
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  EXPECT_EQ(nlohmann::json::parse(eval.out)["scans"], 25);
  const CliResult built = run_cli(out, "build-map --bag " + r.mcap +
                                           " --points /points --ground_truth_topic /ground_truth --voxel 0.2 -o " +
                                           (out / "bag.tsdf").string());
  ASSERT_EQ(built.exit_code, 0) << built.err;
  const CliResult info_bag = run_cli(out, "info --json " + (out / "bag.tsdf").string());
  const CliResult info_folder = run_cli(out, "info --json " + r.map);
  // The same scans at poses equal to 1e-9: the same map, up to voxels on the edge of a decision.
  const auto ib = nlohmann::json::parse(info_bag.out), inf = nlohmann::json::parse(info_folder.out);
  EXPECT_EQ(ib["allocated_blocks"], inf["allocated_blocks"]);
  EXPECT_NEAR(ib["known_voxels"].get<double>(), inf["known_voxels"].get<double>(),
              1e-3 * inf["known_voxels"].get<double>());
}

TEST(CliBag, Ros2BadInputFailsWithOneClearLine) {
  const Ros2Run& r = ros2_run();
  ASSERT_EQ(r.simulate.exit_code, 0) << r.simulate.err;
  TempDir dir;
  const std::string o = " -o " + (dir / "out").string();
  const std::string localize = "localize --map " + r.map + " --backend cpu";
  expect_one_line_error(
      dir, localize + " --bag " + r.mcap + " --points /odom" + o,
      "topic /odom (the points topic) carries nav_msgs/msg/Odometry, not sensor_msgs/msg/PointCloud2");
  expect_one_line_error(dir, localize + " --bag " + r.db3 + " --points /velodyne" + o,
                        "has no topic /velodyne (the points topic); its sensor_msgs/msg/PointCloud2 topics: /points");
  test::write_bytes(dir / "cut.mcap", test::read_bytes(r.mcap).substr(0, 30));
  expect_one_line_error(dir, localize + " --bag " + (dir / "cut.mcap").string() + " --points /points" + o,
                        "truncated or corrupt MCAP file");
  test::write_bytes(dir / "text.db3", "SQLite format 3");
  expect_one_line_error(dir, localize + " --bag " + (dir / "text.db3").string() + " --points /points" + o,
                        "is not a bag: neither a ROS 1 bag");
  expect_one_line_error(dir, "simulate --length 1 --bag " + r.folder + o, "it is a folder");
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
  const CliResult help = run_cli(dir, "localize --help");
  EXPECT_NE(help.out.find("(rosbag2: its folder, or a .db3 or .mcap file; SQLite3 or MCAP, CDR)"), std::string::npos)
      << help.out;
  EXPECT_NE(run_cli(dir, "simulate --help").out.find("[--bag FILE.bag|FILE.mcap|FILE.db3|FOLDER]"), std::string::npos);
}

}  // namespace
}  // namespace tsdf_mcl
