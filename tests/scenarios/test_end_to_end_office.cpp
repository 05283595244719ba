// The main job in small: simulate the built-in office (mapping run and a separate test route), build the map
// from the mapping scans, localize globally on the test route, evaluate — through the commands a user runs.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "cli_test_support.hpp"

namespace tsdf_mcl {
namespace {

using test::CliResult;
using test::run_cli;
using test::TempDir;

TEST(EndToEnd, OfficeGlobalLocalizationConverges) {
  TempDir dir;
  const std::string mapping = (dir / "mapping").string(), route = (dir / "test").string();
  const std::string map = (dir / "office.tsdf").string(), out = (dir / "run").string();
  // Mapping scans every metre (fewer than the default, enough for a 0.1 m map); a 20 m test route at 10 Hz.
  CliResult r = run_cli(dir, "simulate --scene office --lidar vlp16 --route mapping --scan_spacing 1.0 -o " + mapping);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(dir, "simulate --scene office --lidar vlp16 --route test --seed 2 --length 20 --rate 10 -o " + route);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(dir, "build-map --dataset " + mapping + " --voxel 0.1 -o " + map);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // No priors: the up direction and the sensor height come from the first scan.
  r = run_cli(dir,
              "localize --map " + map + " --dataset " + route + " --init global --particles 20000 --seed 2 -o " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(dir, "evaluate --estimate " + out + "/trajectory.tum --dataset " + route);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json m = nlohmann::json::parse(r.out);
  ASSERT_TRUE(m["converged"].get<bool>()) << r.out;
  EXPECT_LE(m["convergence"]["time_s"].get<double>(), 10.0) << r.out;
  // 0.1 m voxels here (the demo uses 0.05 m): the error bound follows the resolution.
  EXPECT_LE(m["after_convergence"]["ate_rmse_m"].get<double>(), 0.10) << r.out;
  EXPECT_LE(m["after_convergence"]["rotation_rmse_deg"].get<double>(), 2.0) << r.out;
  // evaluate reads the localizer's converged flags from report.json beside the trajectory.
  ASSERT_TRUE(m["false_convergence"].is_object()) << r.out;
  EXPECT_EQ(m["false_convergence"]["false_claims"].get<int>(), 0) << r.out;
  EXPECT_GT(m["false_convergence"]["claimed_converged_scans"].get<int>(), 100) << r.out;
}

// The same from a point-cloud map, as a SLAM system writes one: the mapping scans at their poses as one PCD, the map
// built with and without the mapping trajectory.
TEST(EndToEnd, OfficeFromPointCloudConverges) {
  TempDir dir;
  const std::string mapping = (dir / "mapping").string(), route = (dir / "test").string(),
                    cloud = (dir / "office.pcd").string();
  CliResult r = run_cli(dir, "simulate --scene office --lidar vlp16 --route mapping --scan_spacing 2.0 -o " + mapping);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(dir, "export-cloud --dataset " + mapping + " -o " + cloud);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(dir, "simulate --scene office --lidar vlp16 --route test --seed 3 --length 15 --rate 10 -o " + route);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const std::string& trajectory : {std::string(), " --trajectory " + mapping}) {
    const std::string map = (dir / "office.tsdf").string(), out = (dir / "run").string();
    r = run_cli(dir, "build-map --cloud " + cloud + trajectory + " --voxel 0.1 -o " + map);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("build-map: surface:"), std::string::npos) << r.err;
    r = run_cli(dir, "localize --map " + map + " --dataset " + route +
                         " --init global --particles 20000 --seed 3 --overwrite -o " + out);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    r = run_cli(dir, "evaluate --estimate " + out + "/trajectory.tum --dataset " + route);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json m = nlohmann::json::parse(r.out);
    ASSERT_TRUE(m["converged"].get<bool>()) << trajectory << "\n" << r.out;
    EXPECT_LE(m["convergence"]["time_s"].get<double>(), 10.0) << trajectory << "\n" << r.out;
    EXPECT_LE(m["after_convergence"]["ate_rmse_m"].get<double>(), 0.10) << trajectory << "\n" << r.out;
    EXPECT_EQ(m["false_convergence"]["false_claims"].get<int>(), 0) << trajectory << "\n" << r.out;
  }
}

}  // namespace
}  // namespace tsdf_mcl
