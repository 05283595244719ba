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
  CliResult r = run_cli(dir, "simulate --scene office --lidar vlp16 --route mapping --scan-spacing 1.0 -o " + mapping);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(dir, "simulate --scene office --lidar vlp16 --route test --seed 2 --length 20 --rate 10 -o " + route);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(dir, "build-map --dataset " + mapping + " --voxel 0.1 -o " + map);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(dir, "localize --map " + map + " --dataset " + route +
                       " --init global --particles 20000 --init_max_tilt 0.3 --init_height_band 0.3,0.7 --seed 2 -o " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = run_cli(dir, "evaluate --estimate " + out + "/trajectory.tum --dataset " + route);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json m = nlohmann::json::parse(r.out);
  ASSERT_TRUE(m["converged"].get<bool>()) << r.out;
  EXPECT_LE(m["convergence"]["time_s"].get<double>(), 10.0) << r.out;
  // 0.1 m voxels here (the demo uses 0.05 m): the error bound follows the resolution.
  EXPECT_LE(m["after_convergence"]["ate_rmse_m"].get<double>(), 0.10) << r.out;
  EXPECT_LE(m["after_convergence"]["rotation_rmse_deg"].get<double>(), 2.0) << r.out;
}

}  // namespace
}  // namespace tsdf_mcl
