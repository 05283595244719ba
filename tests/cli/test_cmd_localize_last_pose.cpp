// localize --last_pose_file (off unless given): a run keeps its last converged pose, the next run starts there and,
// where the first scan does not fit, searches the whole map; a file that cannot be used is one line, never an error.
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_test_support.hpp"
#include "office_cli_fixture.hpp"

namespace tsdf_mcl {
namespace {

using test::CliResult;
using test::fixture;
using test::run_cli;
using test::TempDir;

std::string localize(const std::string& extra, const TempDir& out, const std::string& run) {
  return "localize --map " + fixture().map + " --dataset " + fixture().dataset +
         " --backend cpu --particles 20000 --max_particles 20000 --min_particles 300 --init_max_tilt 0.1"
         " --init_height_band 0.6,1.2 --max_beams 256 --update_min_d 0 --update_min_a 0" +
         extra + " -o " + (out / run).string();
}

TEST(CliLastPose, ARunKeepsItsLastConvergedPoseAndTheNextStartsThere) {
  TempDir out;
  const std::string file = (out / "last_pose.json").string();
  CliResult r = run_cli(out, localize("", out, "plain"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(std::filesystem::exists(file)) << "kept without --last_pose_file";

  r = run_cli(out, localize(" --last_pose_file " + file, out, "a"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(std::filesystem::exists(file)) << r.err;
  // The newest converged estimate: the run's last line of trajectory.tum (the filter converges early here).
  std::ifstream tum(out / "a" / "trajectory.tum");
  double t = 0, x = 0, y = 0, z = 0, last_x = 0, last_y = 0, last_z = 0, qx, qy, qz, qw;
  while (tum >> t >> x >> y >> z >> qx >> qy >> qz >> qw) {
    last_x = x;
    last_y = y;
    last_z = z;
  }
  const auto kept = nlohmann::json::parse(test::read_bytes(file));
  EXPECT_NEAR(kept["x"].get<double>(), last_x, 1e-6);
  EXPECT_NEAR(kept["y"].get<double>(), last_y, 1e-6);
  EXPECT_NEAR(kept["z"].get<double>(), last_z, 1e-6);

  // The next run starts at the route's end, where its first scan (the route's start) does not fit: it says so and
  // searches the whole map, and still converges.
  r = run_cli(out, localize(" --last_pose_file " + file, out, "b"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("starting at the last converged pose"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("the first scan does not fit at the last converged pose"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("converged (the filter's own flag) since scan"), std::string::npos) << r.err;

  // An --init pose wins over the kept one.
  r = run_cli(out, localize(" --last_pose_file " + file + " --init global", out, "c"));
  ASSERT_EQ(r.exit_code, 0) << r.err;

  std::ofstream(file) << "not json";
  r = run_cli(out, localize(" --last_pose_file " + file, out, "d"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("not used: not a pose file of this version (corrupt?); searching the whole map"),
            std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace tsdf_mcl
