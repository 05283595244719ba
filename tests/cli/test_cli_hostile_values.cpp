// Hostile values from the command line and in files (issue #21): absurd option values that ran for ever, header
// fields that were accepted silently, and echoed user text with control characters or binary bytes, which must
// stay one escaped line.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "cli_test_support.hpp"

namespace tsdf_mcl {
namespace {

using test::CliResult;
using test::expect_one_line_error;
using test::run_cli;
using test::TempDir;
using test::write_bytes;

std::string quoted(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

const std::string kOnePointPcd =
    "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n";

TEST(CliHostileValues, AbsurdOptionValuesAreRejectedWithTheValidRange) {
  TempDir dir;
  // --duration 1e12 simulated until killed.
  expect_one_line_error(dir, "simulate --scene office --duration 1e12 -o " + quoted(dir / "sim"),
                        "--duration must be in (0, 3600] s, got 1e12");
  expect_one_line_error(dir, "simulate --scene office --length 1e9 -o " + quoted(dir / "sim"),
                        "--length must be in (0, 20000] m, got 1e9");
  EXPECT_FALSE(std::filesystem::exists(dir / "sim"));
  // --voxel 10 --truncation 10000 ran past 20 s.
  write_bytes(dir / "map.pcd", kOnePointPcd);
  const std::string cloud = "build-map --cloud " + quoted(dir / "map.pcd") + " -o " + quoted(dir / "m.tsdf");
  expect_one_line_error(dir, cloud + " --voxel 10 --truncation 10000", "--voxel must be in 0.005..2 m, got 10");
  expect_one_line_error(dir, cloud + " --voxel 0.1 --truncation 10000",
                        "--truncation must be in 0.1..6.4 m (at least the voxel, at most 64 voxels and 10 m), got "
                        "10000 m");
  expect_one_line_error(dir, cloud + " --voxel 0.1 --truncation 0.05", "--truncation must be in 0.1..6.4 m");
  EXPECT_FALSE(std::filesystem::exists(dir / "m.tsdf"));
}

TEST(CliHostileValues, PcdWidthAndHeightMustBeCounts) {
  TempDir dir;
  std::string bad = kOnePointPcd;
  bad.replace(bad.find("WIDTH 1\nHEIGHT 1"), 16, "WIDTH -1\nHEIGHT abc");
  write_bytes(dir / "bad.pcd", bad);
  expect_one_line_error(dir, "build-map --cloud " + quoted(dir / "bad.pcd") + " -o " + quoted(dir / "m.tsdf"),
                        "bad.pcd: PCD WIDTH '-1' is not an integer");
  bad = kOnePointPcd;
  bad.replace(bad.find("HEIGHT 1"), 8, "HEIGHT abc");
  write_bytes(dir / "bad.pcd", bad);
  expect_one_line_error(dir, "build-map --cloud " + quoted(dir / "bad.pcd") + " -o " + quoted(dir / "m.tsdf"),
                        "bad.pcd: PCD HEIGHT 'abc' is not an integer");
}

TEST(CliHostileValues, EchoedControlCharactersAndBinaryBytesStayOneLine) {
  TempDir dir;
  // A newline in a path and in an option value.
  expect_one_line_error(dir, "build-map --dataset " + quoted(dir / "no\nsuch") + " -o " + quoted(dir / "m.tsdf"),
                        "no\\nsuch");
  expect_one_line_error(dir, "simulate --scene 'office\nx' -o " + quoted(dir / "sim"), "office\\nx");
  // Binary bytes (and a carriage return) in a PLY header line.
  write_bytes(dir / "bin.ply", std::string("ply\nformat ascii 1.0\nelement vertex 1\nbogus \x01\xfe\x80\r line\n") +
                                   "end_header\n1 2 3\n");
  const CliResult r = run_cli(dir, "build-map --cloud " + quoted(dir / "bin.ply") + " -o " + quoted(dir / "m.tsdf"));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_NE(r.err.find("bogus \\x01\\xFE\\x80\\r line"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace tsdf_mcl
