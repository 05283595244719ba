#include <gtest/gtest.h>

#include "cli_test_support.hpp"
#include "sim_test_helpers.hpp"
#include "tsdf_mcl/io/dataset.hpp"

using tsdf_mcl::test::run_cli;
using tsdf_mcl::test::TempDir;

TEST(SimCli, ShortRunWritesADatasetAndASummary) {
  TempDir dir;
  const auto run = run_cli(
      "simulate --scene office --lidar os0-64 --route test --seed 3 --length 3 --obstacles 1 "
      "--motion_distortion -o " +
          (dir / "out").string(),
      dir.path());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("scans"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("route 3.0 m"), std::string::npos) << run.output;
  const tsdf_mcl::Dataset ds = tsdf_mcl::Dataset::open(dir / "out");
  EXPECT_GT(ds.size(), 10u);
  EXPECT_TRUE(ds.has_poses() && ds.has_odometry());
}

TEST(SimCli, HelpListsOptionsWithDefaults) {
  TempDir dir;
  const auto run = run_cli("simulate --help", dir.path());
  ASSERT_EQ(run.exit_code, 0);
  for (const char* text :
       {"--scene", "[default: office]", "symmetric", "warehouse", "--lidar", "--route", "--odom_noise",
        "[default: 0.1]", "--motion_distortion", "--obstacles", "--ground_plane", "--platform", "ground|handheld|drone",
        "[default: ground]", "--sensor_tilt", "--start", "--waypoints", "--walkers", "-o, --output DIR"}) {
    EXPECT_NE(run.output.find(text), std::string::npos) << text;
  }
}

// Each bad input ends with exit code 1 and one line naming what is wrong.
TEST(SimCli, BadInputFailsWithOneClearLine) {
  TempDir dir;
  tsdf_mcl::test::write_bytes(dir / "not_a_dir", "x");
  // A mesh with nothing to drive on: one upright quad.
  tsdf_mcl::TriangleMesh wall;
  wall.vertices = {{0, 0, 0}, {5, 0, 0}, {5, 0, 3}, {0, 0, 3}};
  wall.triangles = {{0, 1, 2}, {0, 2, 3}};
  tsdf_mcl::save_mesh_ply(wall, dir / "wall.ply");
  const std::string out = " -o " + (dir / "out").string();
  const std::pair<std::string, std::string> cases[] = {
      {"simulate --scene castle" + out, "castle"},
      {"simulate --scene " + (dir / "missing.stl").string() + out, "missing.stl"},
      {"simulate --lidar hdl64" + out, "hdl64"},
      {"simulate --speed fast" + out, "--speed"},
      {"simulate --seed -3" + out, "--seed"},
      {"simulate --dropout 1.5" + out, "dropout"},
      {"simulate --rate 30" + out, "5-20 Hz"},
      {"simulate --route loop" + out, "--route"},
      {"simulate --duration 10 --length 5" + out, "not both"},
      {"simulate --route mapping --obstacles 3" + out, "obstacles"},
      {"simulate --frobnicate 1" + out, "--frobnicate"},
      {"simulate --scene office", "-o DIR"},
      {"simulate --length 2 -o " + (dir / "not_a_dir").string(), "not_a_dir"},
      {"simulate --scene " + (dir / "wall.ply").string() + out, "no traversable floor"},
  };
  for (const auto& [arguments, expected] : cases) {
    const auto run = run_cli(arguments, dir.path());
    EXPECT_EQ(run.exit_code, 1) << arguments << "\n" << run.output;
    EXPECT_NE(run.output.find(expected), std::string::npos) << arguments << "\n" << run.output;
    const auto errors = std::count(run.output.begin(), run.output.end(), '\n');
    const bool one_error_line = run.output.find("error:") != std::string::npos &&
                                run.output.find('\n', run.output.find("error:")) + 1 == run.output.size();
    EXPECT_TRUE(one_error_line) << arguments << "\n" << run.output << "(" << errors << " lines)";
  }
}

TEST(SimCli, ScenePlatformAndRouteOptionsRejectBadValues) {
  TempDir dir;
  const std::pair<std::string, std::string> cases[] = {
      {"--platform boat", "--platform"},
      {"--sensor_tilt steep", "--sensor_tilt"},
      {"--sensor_tilt 120", "sensor tilt"},
      {"--platform drone --sensor_height 2", "--sensor_height"},
      {"--start 1,2", "--start"},
      {"--start 1,2,x", "--start"},
      {"--waypoints '3,10;4'", "--waypoints"},
      {"--waypoints '3,10;;4,10'", "--waypoints"},
      {"--waypoints '3,10;90,10'", "waypoint 2 (90.00, 10.00)"},
      {"--start 3,30,0", "route start"},
      {"--route mapping --waypoints '3,10;8,10'", "test routes"},
      {"--scene castle", "office, symmetric, warehouse, two-storey"},
      {"--storey 1", "the scene has one storey (0)"},
      {"--scene two-storey --storey 2", "the scene has 2 storeys (0 to 1)"},
      {"--scene two-storey --route mapping --storey 1", "--storey"},
      {"--route mapping --walkers 2", "walkers"},
      {"--walkers 60", "at most 50 walkers"},
  };
  for (const auto& [options, words] : cases) {
    tsdf_mcl::test::expect_one_line_error(dir, "simulate " + options + " -o " + (dir / "out").string(), words);
  }
}

// A scripted handheld walk through the symmetric building: from the west wing to the landmark's room.
TEST(SimCli, ScriptedWalkToTheLandmark) {
  TempDir dir;
  const auto run = tsdf_mcl::test::run_cli(
      dir,
      "simulate --scene symmetric --platform handheld --rate 5 --scan_spacing 0.5 --start 3,8,0 "
      "--waypoints '33.8,8;33.8,4.6' -o " +
          (dir / "out").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("on handheld"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("the landmark is first in view in scan"), std::string::npos) << run.err;
  const tsdf_mcl::Dataset ds = tsdf_mcl::Dataset::open(dir / "out");
  EXPECT_NEAR(ds.pose(0).translation().z(), 1.5, 0.03);
  // The last scan kept (one per 0.5 m) is near the last waypoint.
  EXPECT_LT((ds.pose(ds.size() - 1).translation().head<2>() - Eigen::Vector2d(33.8, 4.6)).norm(), 0.55);
}
