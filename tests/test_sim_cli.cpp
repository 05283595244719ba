#include <gtest/gtest.h>

#include "sim_test_helpers.hpp"
#include "tsdf_mcl/dataset.hpp"

using tsdf_mcl::test::run_cli;
using tsdf_mcl::test::TempDir;

TEST(SimCli, ShortRunWritesADatasetAndASummary) {
  TempDir dir;
  const auto run = run_cli(
      "simulate --scene office --lidar os0-64 --route test --seed 3 --length 3 --obstacles 1 "
      "--motion-distortion -o " +
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
  for (const char* text : {"--scene", "[default: office]", "--lidar", "--route", "--odom-noise", "[default: 0.1]",
                           "--motion-distortion", "--obstacles", "--ground-plane", "-o, --output DIR"}) {
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
