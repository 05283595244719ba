// Hostile input from the command line (issue #10): corrupt size fields, tiny files that would need gigabytes,
// unbounded counts, out-of-range map headers, silently accepted nonsense and non-regular files. Each bad input
// ends in exactly one error line and a non-zero exit, quickly and within the documented limits.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstring>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/map/map_io.hpp"

namespace tsdf_mcl {
namespace {

using test::CliResult;
using test::expect_one_line_error;
using test::read_bytes;
using test::run_cli;
using test::TempDir;
using test::write_bytes;

std::string quoted(const std::filesystem::path& p) { return "'" + p.string() + "'"; }

// A one-scan dataset whose scan file holds `scan_bytes` under `scan_name`; poses and times as given.
std::filesystem::path one_scan_dataset(const TempDir& dir, const std::string& name, const std::string& scan_name,
                                       const std::string& scan_bytes,
                                       const std::string& pose_line = "1 0 0 0 0 1 0 0 0 0 1 0\n",
                                       const std::string& times = "0.0\n") {
  const std::filesystem::path ds = dir / name;
  std::filesystem::create_directories(ds / "scans");
  write_bytes(ds / "times.txt", times);
  write_bytes(ds / "poses.txt", pose_line);
  write_bytes(ds / "scans" / scan_name, scan_bytes);
  return ds;
}

std::string pcd(const std::string& header_lines, std::size_t payload_bytes) {
  return "VERSION 0.7\n" + header_lines + "DATA binary\n" + std::string(payload_bytes, '\0');
}

// A binary STL of the given triangles (corner coordinates, normals zero).
std::string binary_stl(const std::vector<std::array<Eigen::Vector3f, 3>>& triangles) {
  std::string out(80, ' ');
  auto put = [&out](auto value) { out.append(reinterpret_cast<const char*>(&value), sizeof(value)); };
  put(static_cast<std::uint32_t>(triangles.size()));
  for (const auto& t : triangles) {
    for (int k = 0; k < 3; ++k) put(0.0f);
    for (const Eigen::Vector3f& v : t)
      for (int a = 0; a < 3; ++a) put(v[a]);
    put(std::uint16_t{0});
  }
  return out;
}

TEST(CliHostile, PcdSizeFieldsAreCheckedBeforeReading) {
  TempDir dir;
  const std::string out = " -o " + quoted(dir / "m.tsdf");
  const std::string xyz = "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n";
  // COUNT 0 gave a zero stride and a read far beyond the buffer (SIGSEGV).
  auto ds = one_scan_dataset(dir, "count0", "000000.pcd", pcd(xyz + "COUNT 0 0 0\nPOINTS 1000\n", 64));
  expect_one_line_error(dir, "build-map --dataset " + quoted(ds) + out, "COUNT 0");
  ds = one_scan_dataset(dir, "negative", "000000.pcd", pcd(xyz + "COUNT 1 -1 1\nPOINTS 10\n", 64));
  expect_one_line_error(dir, "build-map --dataset " + quoted(ds) + out, "PCD COUNT '-1'");
  // SIZE * COUNT overflowing int wrapped the stride.
  ds = one_scan_dataset(dir, "wrap", "000000.pcd",
                        pcd("FIELDS x y z w\nSIZE 4 4 4 8\nTYPE F F F F\nCOUNT 1 1 1 536870912\nPOINTS 10\n", 64));
  expect_one_line_error(dir, "build-map --dataset " + quoted(ds) + out, "PCD COUNT '536870912'");
  // POINTS -5 parsed as 2^64 - 5 and reached reserve().
  ds = one_scan_dataset(dir, "points", "000000.pcd", pcd(xyz + "POINTS -5\n", 64));
  expect_one_line_error(dir, "build-map --dataset " + quoted(ds) + out, "PCD POINTS '-5'");
  // More points than the file holds.
  ds = one_scan_dataset(dir, "short", "000000.pcd", pcd(xyz + "POINTS 1000\n", 120));
  expect_one_line_error(dir, "build-map --dataset " + quoted(ds) + out, "PCD data truncated");
  EXPECT_FALSE(std::filesystem::exists(dir / "m.tsdf"));
}

TEST(CliHostile, TinyMeshesThatWouldNeedGigabytesHitTheBudget) {
  TempDir dir;
  const std::string out = " -o " + quoted(dir / "m.tsdf");
  // 134 bytes: one 200 km x 10 m triangle (drove build-map past 16 GB).
  write_bytes(dir / "sliver.stl", binary_stl({{{{0, 0, 0}, {200000, 0, 0}, {0, 10, 0}}}}));
  expect_one_line_error(dir, "build-map --mesh " + quoted(dir / "sliver.stl") + " --max_memory 256" + out,
                        "memory budget of 256 MiB");
  // A box with one vertex 200 km away along x (minutes at 8 GB), and one far away diagonally.
  const std::vector<std::array<int, 4>> quads = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                                 {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& [name, far] : {std::pair{"far_x.stl", Eigen::Vector3f(200000, 1, 1)},
                                  std::pair{"far_xy.stl", Eigen::Vector3f(3000, 3000, 1)}}) {
    std::vector<Eigen::Vector3f> v;
    for (int i = 0; i < 8; ++i) v.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
    v[7] = far;
    std::vector<std::array<Eigen::Vector3f, 3>> triangles;
    for (const auto& q : quads) {
      triangles.push_back({v[q[0]], v[q[1]], v[q[2]]});
      triangles.push_back({v[q[0]], v[q[2]], v[q[3]]});
    }
    write_bytes(dir / name, binary_stl(triangles));
  }
  expect_one_line_error(dir, "build-map --mesh " + quoted(dir / "far_x.stl") + " --max_memory 256" + out,
                        "memory budget of 256 MiB");
  expect_one_line_error(dir, "build-map --mesh " + quoted(dir / "far_xy.stl") + " --max_memory 256" + out,
                        "map bounding box too large");
  // A sliver along the diagonal of a box within the limits: the work follows the triangle, not its bounding box.
  write_bytes(dir / "diagonal.stl", binary_stl({{{{0, 0, 0}, {600, 600, 0}, {600.2f, 600, 0}}}}));
  const CliResult r =
      run_cli(dir, "build-map --mesh " + quoted(dir / "diagonal.stl") + " --voxel 0.1 --margin 0" + out);
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

TEST(CliHostile, PlyCountsMustFitTheFile) {
  TempDir dir;
  const std::string out = " -o " + quoted(dir / "m.tsdf");
  const std::string body =
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  // An element without properties and 10^18 rows looped effectively forever.
  write_bytes(dir / "endless.ply", "ply\nformat binary_little_endian 1.0\nelement junk 1000000000000000000\n" + body +
                                       std::string(64, '\0'));
  expect_one_line_error(dir, "build-map --mesh " + quoted(dir / "endless.ply") + out, "more than the limit");
  write_bytes(dir / "empty_rows.ply",
              "ply\nformat binary_little_endian 1.0\nelement junk 1000\n" + body + std::string(64, '\0'));
  expect_one_line_error(dir, "build-map --mesh " + quoted(dir / "empty_rows.ply") + out, "no properties");
  // Counts the file cannot hold must not size memory.
  write_bytes(dir / "huge.ply",
              "ply\nformat ascii 1.0\nelement vertex 200000000\nproperty float x\nproperty float y\n"
              "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
              "end_header\n0 0 0\n");
  expect_one_line_error(dir, "build-map --mesh " + quoted(dir / "huge.ply") + out, "truncated or corrupt");
}

TEST(CliHostile, MapHeaderOutOfRangeAndNonRegularFiles) {
  TempDir dir;
  TsdfMap map = TsdfMap::covering(0.1f, 0.3f, {0, 0, 0}, {1, 1, 1});
  map.set_distance({1, 1, 1}, 0.1f);
  save_map(map, dir / "good.tsdf");
  std::string bytes = read_bytes(dir / "good.tsdf");
  test::put_u32(bytes, 24, 0x80000010u);  // min_block.x near -2^31, with a valid checksum
  test::put_u32(bytes, bytes.size() - 4, test::crc32_bitwise(bytes.substr(0, bytes.size() - 4)));
  write_bytes(dir / "far.tsdf", bytes);
  expect_one_line_error(dir, "info " + quoted(dir / "far.tsdf"), "header out of range");
  expect_one_line_error(dir, "render --map " + quoted(dir / "far.tsdf") + " -o " + quoted(dir / "x.png"),
                        "header out of range");

  // A FIFO blocked `info` forever.
  ASSERT_EQ(::mkfifo((dir / "fifo.tsdf").c_str(), 0600), 0) << std::strerror(errno);
  expect_one_line_error(dir, "info " + quoted(dir / "fifo.tsdf"), "not a regular file");
  expect_one_line_error(dir, "build-map --mesh " + quoted(dir / "fifo.tsdf") + " -o " + quoted(dir / "m.tsdf"),
                        "unknown extension");
  ASSERT_EQ(::mkfifo((dir / "fifo.stl").c_str(), 0600), 0);
  expect_one_line_error(dir, "build-map --mesh " + quoted(dir / "fifo.stl") + " -o " + quoted(dir / "m.tsdf"),
                        "not a regular file");
}

TEST(CliHostile, NonsensePosesTimesAndEmptyScansAreRejected) {
  TempDir dir;
  const std::string out = " -o " + quoted(dir / "m.tsdf");
  PointCloud cloud;
  cloud.points = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  write_kitti_bin(dir / "scan.bin", cloud);
  const std::string scan = read_bytes(dir / "scan.bin");
  // Twelve zeros became a 180-degree roll; a mirror was accepted.
  auto ds = one_scan_dataset(dir, "zeros", "000000.bin", scan, "0 0 0 0 0 0 0 0 0 0 0 0\n");
  expect_one_line_error(dir, "build-map --dataset " + quoted(ds) + out, "poses.txt:1: not a rotation");
  ds = one_scan_dataset(dir, "mirror", "000000.bin", scan, "-1 0 0 0 0 1 0 0 0 0 1 0\n");
  expect_one_line_error(dir, "build-map --dataset " + quoted(ds) + out, "det R = -1");
  // times.txt ignored trailing junk.
  ds = one_scan_dataset(dir, "junk", "000000.bin", scan, "1 0 0 0 0 1 0 0 0 0 1 0\n", "0.5 garbage\n");
  expect_one_line_error(dir, "build-map --dataset " + quoted(ds) + out, "times.txt:1: expected one timestamp");
  // build-map skipped empty scans that localize rejects: one policy now.
  ds = one_scan_dataset(dir, "empty", "000000.bin", "");
  expect_one_line_error(dir, "build-map --dataset " + quoted(ds) + out, "000000.bin: empty scan file");
  PointCloud nan_cloud;
  nan_cloud.points = {{std::nanf(""), 0, 0}};
  write_kitti_bin(dir / "nan.bin", nan_cloud);
  ds = one_scan_dataset(dir, "nan", "000000.bin", read_bytes(dir / "nan.bin"));
  expect_one_line_error(dir, "build-map --dataset " + quoted(ds) + out, "no finite points");
  EXPECT_FALSE(std::filesystem::exists(dir / "m.tsdf"));
}

TEST(CliHostile, OutputPathsAreCheckedBeforeTheWork) {
  TempDir dir;
  test::write_binary_stl(test::box_mesh({0, 0, 0}, {1, 1, 1}), dir / "box.stl");
  std::filesystem::create_directory(dir / "folder");
  // The map used to be built completely before the folder was found.
  expect_one_line_error(dir, "build-map --mesh " + quoted(dir / "box.stl") + " -o " + quoted(dir / "folder"),
                        "it is a folder");
  // No temporary files are left beside a written map.
  const CliResult r = run_cli(dir, "build-map --mesh " + quoted(dir / "box.stl") + " -o " + quoted(dir / "box.tsdf"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(entry.path().string().find("partial"), std::string::npos) << entry.path();
  }
}

TEST(CliHostile, RenderFarPositionsStayWithinPixelArithmetic) {
  TempDir dir;
  TsdfMap map = TsdfMap::covering(0.1f, 0.3f, {0, 0, 0}, {2, 2, 1});
  map.set_distance({3, 3, 3}, -0.05f);
  save_map(map, dir / "m.tsdf");
  // Positions beyond ~1e8 m overflowed the pixel coordinates (undefined behaviour; the image was still written).
  write_bytes(dir / "far.tum", "0 1 1 0 0 0 0 1\n1 1e12 -3e11 0 0 0 0 1\n2 -1e15 1e15 0 0 0 0 1\n");
  const CliResult r = run_cli(dir, "render --map " + quoted(dir / "m.tsdf") + " --estimate " + quoted(dir / "far.tum") +
                                       " -o " + quoted(dir / "far.png"));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read_bytes(dir / "far.png").substr(1, 3), "PNG");
}

}  // namespace
}  // namespace tsdf_mcl
