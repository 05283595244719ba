// Pose inputs of localize checked against the map's extent (issue 52): values that used to give a trajectory of
// inf, NaN or 1e30 m with exit 0 are now one error line, and nothing is written.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "cli_test_support.hpp"
#include "office_cli_fixture.hpp"

namespace tsdf_mcl {
namespace {

using test::expect_one_line_error;
using test::fixture;
using test::TempDir;

const std::string kBase = " --backend cpu --particles 200 --count 4";

std::string localize(const std::string& dataset, const std::string& extra, const TempDir& out) {
  return "localize --map " + fixture().map + " --dataset " + dataset + kBase + extra + " -o " + (out / "run").string();
}

TEST(CliPoseRanges, InitialPosesAndSpreadsBeyondTheMapAreRefused) {
  TempDir out;
  const std::string d = fixture().dataset;
  const std::string outside = "the initial pose (init, initial_pose.*) lies outside the map: x = ";
  expect_one_line_error(out, localize(d, " --init 1e300,0,0,0,0,0", out), outside + "1e+300 m");
  expect_one_line_error(out, localize(d, " --init 1e30,1,1,0,0,0", out), outside + "1e+30 m");
  expect_one_line_error(out, localize(d, " --init initial_pose --initial_pose.x 1e300", out), outside + "1e+300 m");
  expect_one_line_error(out, localize(d, " --init 3,2,1e4,0,0,0", out), "lies outside the map: z = 10000 m");
  expect_one_line_error(out, localize(d, " --init 3,2,1,0,0,0 --init_sigma_xy 1e300", out),
                        "init_sigma_xy 1e+300 m is larger than the map's diagonal");
  expect_one_line_error(out, localize(d, " --init 3,2,1,0,0,0 --init_sigma_z 1e300", out), "init_sigma_z 1e+300 m");
  expect_one_line_error(out, localize(d, " --motion_model diffusion --diffusion_xy 1e30", out),
                        "diffusion_xy 1e+30 m is larger than the map's diagonal");
  expect_one_line_error(out, localize(d, " --alpha3 1e30", out), "alpha3 1e+30 is more than 10: odometry noise");
  expect_one_line_error(out, localize(d, " --init_height_band 0,1e300", out),
                        "init_height_band 1e+300 m lies beyond the map's height");
  test::write_bytes(out / "init.yaml", "init: [1e30, 0, 0, 0, 0, 0]\n");
  expect_one_line_error(out, localize(d, " --config " + (out / "init.yaml").string(), out), outside + "1e+30 m");
  EXPECT_FALSE(std::filesystem::exists(out / "run"));
}

TEST(CliPoseRanges, OdometryAndStampsBeyondTheirRangesAreRefused) {
  TempDir out;
  const std::filesystem::path d = out / "data";
  std::filesystem::copy(fixture().dataset, d, std::filesystem::copy_options::recursive);
  const std::string odom = test::read_bytes(d / "odom.txt");
  const std::size_t line3 = odom.find('\n', odom.find('\n') + 1) + 1;
  std::string far = odom;
  far.replace(line3, far.find('\n', line3) - line3, "1 0 0 1e30 0 1 0 0 0 0 1 0");
  test::write_bytes(d / "odom.txt", far);
  expect_one_line_error(out, localize(d.string(), "", out), "odom.txt:3: a translation beyond +-2^28 m");
  // Within any map's reach, but farther in one step than this map is wide (the localizer's check).
  far.replace(line3, far.find('\n', line3) - line3, "1 0 0 1e6 0 1 0 0 0 0 1 0");
  test::write_bytes(d / "odom.txt", far);
  expect_one_line_error(out, localize(d.string(), "", out), "000002.bin: the scan's odometry moved ");
  expect_one_line_error(out, localize(d.string(), "", out), "m since the scan before, more than the map's diagonal");
  test::write_bytes(d / "odom.txt", odom);
  const std::string times = test::read_bytes(d / "times.txt");
  std::string late = times;
  late.replace(late.rfind('\n', late.size() - 2) + 1, std::string::npos, "1e300\n");
  test::write_bytes(d / "times.txt", late);
  expect_one_line_error(out, localize(d.string(), "", out), "times.txt:24: timestamp 1e300 lies beyond +-2^32 s");
  EXPECT_FALSE(std::filesystem::exists(out / "run"));
}

}  // namespace
}  // namespace tsdf_mcl
