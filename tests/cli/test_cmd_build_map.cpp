#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_test_support.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/map/map_io.hpp"
#include "checkout_paths.hpp"

using tsdf_mcl::test::read_bytes;
using tsdf_mcl::test::TempDir;

using tsdf_mcl::test::CliResult;
using tsdf_mcl::test::expect_one_line_error;
using tsdf_mcl::test::run_cli;

namespace {}  // namespace

TEST(CliMap, BuildMapRejectsBadInput) {
  TempDir dir;
  const std::string d = "'" + dir.path().string() + "'";
  tsdf_mcl::test::write_binary_stl(tsdf_mcl::test::box_mesh({0, 0, 0}, {1, 1, 1}), dir / "box.stl");
  const std::string box = d + "/box.stl";
  expect_one_line_error(dir, "build-map -o " + d + "/m.tsdf", "no source");
  expect_one_line_error(dir, "build-map --mesh " + box + " --dataset " + d + " -o " + d + "/m.tsdf", "only one source");
  expect_one_line_error(dir, "build-map --mesh " + box, "missing -o");
  expect_one_line_error(dir, "build-map --mesh " + d + "/nothing.stl -o " + d + "/m.tsdf", "does not exist");
  expect_one_line_error(dir, "build-map --mesh " + box + " --voxel abc -o " + d + "/m.tsdf",
                        "--voxel expects a number");
  expect_one_line_error(dir, "build-map --mesh " + box + " --voxel 0 -o " + d + "/m.tsdf",
                        "--voxel must be in 0.005..2 m");
  expect_one_line_error(dir, "build-map --mesh " + box + " --voxel -0.1 -o " + d + "/m.tsdf",
                        "--voxel must be in 0.005..2 m");
  expect_one_line_error(dir, "build-map --mesh " + box + " --truncation 0.02 -o " + d + "/m.tsdf",
                        "(at least the voxel, at most 64 voxels and 10 m)");
  expect_one_line_error(dir, "build-map --mesh " + box + " --colour red -o " + d + "/m.tsdf",
                        "unknown option --colour");
  expect_one_line_error(dir, "build-map --mesh " + box + " -o " + d + "/no/such/dir/m.tsdf", "does not exist");
  expect_one_line_error(dir, "build-map --mesh " + box + " --stride 2 -o " + d + "/m.tsdf",
                        "applies to --dataset and --bag only");
  expect_one_line_error(dir, "build-map --dataset " + d + "/nowhere -o " + d + "/m.tsdf", "is not a directory");
  expect_one_line_error(dir, "build-map --import_h5 " + box + " --voxel 0.1 -o " + d + "/m.tsdf", "0.064 m voxels");
  expect_one_line_error(dir, "build-map --import_h5 " + box + " -o " + d + "/m.tsdf", "not an HDF5 file");
  tsdf_mcl::test::write_bytes(dir / "broken.stl", "solid x\nfacet normal 0 0 1\n");
  expect_one_line_error(dir, "build-map --mesh " + d + "/broken.stl -o " + d + "/m.tsdf", "truncated");
  // A fuzzer's find: a corrupt local heap that makes libhdf5 1.10 itself crash (SIGSEGV in H5G__stab_lookup)
  // before the importer sees any data. The import runs in a child process: the crash is one error line.
  expect_one_line_error(dir,
                        std::string("build-map --import_h5 '") + tsdf_mcl::test::test_data_dir() +
                            "/libhdf5_crash_local_heap.h5' -o " + d + "/m.tsdf",
                        "the HDF5 library crashed reading it");
  EXPECT_FALSE(std::filesystem::exists(dir / "m.tsdf"));
}

TEST(CliMap, InfoRejectsBadInput) {
  TempDir dir;
  const std::string d = "'" + dir.path().string() + "'";
  expect_one_line_error(dir, "info", "expected one map file");
  expect_one_line_error(dir, "info " + d + "/missing.tsdf", "does not exist");
  tsdf_mcl::test::write_bytes(dir / "junk.tsdf", "not a map at all");
  expect_one_line_error(dir, "info " + d + "/junk.tsdf", "not a tsdf-mcl map");
  tsdf_mcl::TsdfMap map = tsdf_mcl::TsdfMap::covering(0.1f, 0.3f, {0, 0, 0}, {2, 2, 2});
  map.set_distance({3, 4, 5}, 0.1f);
  tsdf_mcl::save_map(map, dir / "good.tsdf");
  std::string bytes = read_bytes(dir / "good.tsdf");
  bytes[bytes.size() - 100] = static_cast<char>(bytes[bytes.size() - 100] ^ 1);
  tsdf_mcl::test::write_bytes(dir / "corrupt.tsdf", bytes);
  expect_one_line_error(dir, "info " + d + "/corrupt.tsdf", "checksum mismatch");
  expect_one_line_error(dir, "info " + d + "/good.tsdf " + d + "/good.tsdf", "expected one map file");
}

TEST(CliMap, BuildMapRejectsUnusableDatasets) {
  TempDir dir;
  const std::string d = "'" + dir.path().string() + "'";
  {
    tsdf_mcl::DatasetWriter writer(dir / "noposes");
    tsdf_mcl::PointCloud cloud;
    cloud.points = {{1, 0, 0}, {0, 1, 0}};
    writer.add(0.0, cloud, std::nullopt, std::nullopt);
  }
  expect_one_line_error(dir, "build-map --dataset " + d + "/noposes -o " + d + "/m.tsdf", "has no poses.txt");
  {
    tsdf_mcl::DatasetWriter writer(dir / "one");
    tsdf_mcl::PointCloud cloud;
    cloud.points = {{1, 0, 0}, {0, 1, 0}};
    writer.add(0.0, cloud, tsdf_mcl::Pose::Identity(), std::nullopt);
  }
  expect_one_line_error(dir, "build-map --dataset " + d + "/one --start 3 -o " + d + "/m.tsdf", "selects none");
  expect_one_line_error(dir, "build-map --dataset " + d + "/one --stride 0 -o " + d + "/m.tsdf", "--stride");
  expect_one_line_error(dir, "build-map --dataset " + d + "/one --count -2 -o " + d + "/m.tsdf",
                        "--count must not be negative");
}

TEST(CliMap, BuildMapFromMeshThenInfo) {
  TempDir dir;
  const std::string d = "'" + dir.path().string() + "'";
  tsdf_mcl::test::write_binary_stl(tsdf_mcl::test::box_mesh({-1.0f, -0.8f, -0.5f}, {1.2f, 0.9f, 0.7f}),
                                   dir / "box.stl");
  const CliResult build =
      run_cli(dir, "build-map --mesh " + d + "/box.stl --voxel 0.1 --truncation 0.3 -o " + d + "/box.tsdf");
  ASSERT_EQ(build.exit_code, 0) << build.err;
  EXPECT_NE(build.err.find("wrote"), std::string::npos) << build.err;
  ASSERT_TRUE(std::filesystem::exists(dir / "box.tsdf"));

  const CliResult info = run_cli(dir, "info " + d + "/box.tsdf");
  ASSERT_EQ(info.exit_code, 0) << info.err;
  for (const char* line : {"resolution:   0.100 m", "truncation:   0.300 m",
                           "extent:", "blocks:", "memory:", "known volume:", "free volume:"}) {
    EXPECT_NE(info.out.find(line), std::string::npos) << "'" << line << "' missing from\n" << info.out;
  }
  const CliResult json = run_cli(dir, "info --json " + d + "/box.tsdf");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  const nlohmann::json j = nlohmann::json::parse(json.out);
  EXPECT_NEAR(j.at("voxel_size").get<double>(), 0.1, 1e-6);
  EXPECT_GT(j.at("allocated_blocks").get<int>(), 0);
  EXPECT_GT(j.at("free_blocks").get<int>(), 0);
  // Known volume: the map box minus the box's unknown core; free volume: the box's outside, within the map.
  const auto size = j.at("size");
  const double box_m3 = size[0].get<double>() * size[1].get<double>() * size[2].get<double>();
  EXPECT_LT(j.at("free_volume_m3").get<double>(), box_m3 - 2.2 * 1.7 * 1.2 + 0.5);
  EXPECT_GT(j.at("free_volume_m3").get<double>(), 0.5 * box_m3);

  const CliResult help = run_cli(dir, "build-map --help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_NE(help.out.find("-o, --output MAP"), std::string::npos) << help.out;
  EXPECT_NE(help.out.find("[default: 0.05]"), std::string::npos) << help.out;
}
