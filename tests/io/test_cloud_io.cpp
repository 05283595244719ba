// Map clouds: PCD (ascii, binary, binary_compressed) and PLY (ascii, binary) read in chunks; hostile headers end in
// one clear error, before any memory is sized by them.
#include <gtest/gtest.h>

#include <cstring>

#include "cli_test_support.hpp"
#include "tsdf_mcl/io/pcd_format.hpp"
#include "tsdf_mcl/io/cloud_io.hpp"
#include "tsdf_mcl/core/error.hpp"

using Eigen::Vector3f;
using tsdf_mcl::test::expect_one_line_error;
using tsdf_mcl::test::TempDir;
using tsdf_mcl::test::write_bytes;

namespace {

template <typename T>
void put(std::string& out, T v, bool big_endian = false) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &v, sizeof(T));
  if (big_endian) std::reverse(bytes, bytes + sizeof(T));
  out.append(bytes, sizeof(T));
}

const std::vector<Vector3f> kPoints = {{1.5f, -2.0f, 0.25f}, {0.0f, 0.0f, 0.0f}, {-3.0f, 4.0f, 5.5f}};

void expect_points(const std::vector<Vector3f>& got) {
  ASSERT_EQ(got.size(), kPoints.size());
  for (std::size_t i = 0; i < got.size(); ++i)
    EXPECT_TRUE(got[i].isApprox(kPoints[i], 1e-6f)) << i << ": " << got[i].transpose();
}

// LZF with literal runs only (valid LZF: a control byte below 32 announces that many + 1 literal bytes).
std::string lzf_literals(const std::string& data) {
  std::string out;
  for (std::size_t i = 0; i < data.size(); i += 32) {
    const std::size_t n = std::min<std::size_t>(32, data.size() - i);
    out.push_back(static_cast<char>(n - 1));
    out.append(data, i, n);
  }
  return out;
}

std::string expect_error(const std::filesystem::path& file) {
  try {
    tsdf_mcl::read_cloud(file);
  } catch (const tsdf_mcl::Error& e) {
    return e.what();
  }
  ADD_FAILURE() << file << " read without an error";
  return {};
}

TEST(CloudIo, PcdEncodings) {
  TempDir dir;
  tsdf_mcl::write_pcd(dir / "binary.pcd", kPoints);
  expect_points(tsdf_mcl::read_cloud(dir / "binary.pcd"));

  // ascii with more fields than x y z (as FAST-LIO writes: intensity, normals, curvature).
  std::string ascii =
      "VERSION 0.7\nFIELDS x y z intensity normal_x normal_y normal_z curvature\nSIZE 4 4 4 4 4 4 4 4\n"
      "TYPE F F F F F F F F\nCOUNT 1 1 1 1 1 1 1 1\nWIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA ascii\n";
  for (const Vector3f& p : kPoints)
    ascii += std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) + " 7 0 0 1 0\n";
  write_bytes(dir / "ascii.pcd", ascii);
  expect_points(tsdf_mcl::read_cloud(dir / "ascii.pcd"));

  // binary with float64 coordinates after a uint16 field.
  std::string binary =
      "VERSION 0.7\nFIELDS ring x y z\nSIZE 2 8 8 8\nTYPE U F F F\nCOUNT 1 1 1 1\nPOINTS 3\nDATA binary\n";
  for (const Vector3f& p : kPoints) {
    put<std::uint16_t>(binary, 3);
    for (int a = 0; a < 3; ++a) put<double>(binary, p[a]);
  }
  write_bytes(dir / "double.pcd", binary);
  expect_points(tsdf_mcl::read_cloud(dir / "double.pcd"));

  // binary_compressed: the fields one after the other (all x, all y, all z, all intensity), LZF-compressed.
  std::string fields;
  for (int a = 0; a < 4; ++a) {
    for (const Vector3f& p : kPoints) put<float>(fields, a < 3 ? p[a] : 1.0f);
  }
  const std::string packed = lzf_literals(fields);
  std::string compressed =
      "VERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\nPOINTS 3\nDATA "
      "binary_compressed\n";
  put<std::uint32_t>(compressed, static_cast<std::uint32_t>(packed.size()));
  put<std::uint32_t>(compressed, static_cast<std::uint32_t>(fields.size()));
  write_bytes(dir / "compressed.pcd", compressed + packed);
  expect_points(tsdf_mcl::read_cloud(dir / "compressed.pcd"));

  // Chunks: a reader hands out at most the asked number of points.
  tsdf_mcl::CloudReader reader(dir / "compressed.pcd");
  EXPECT_EQ(reader.size_hint(), 3u);
  std::vector<Vector3f> chunk;
  ASSERT_TRUE(reader.next(chunk, 2));
  EXPECT_EQ(chunk.size(), 2u);
  ASSERT_TRUE(reader.next(chunk, 2));
  EXPECT_EQ(chunk.size(), 1u);
  EXPECT_FALSE(reader.next(chunk, 2));
}

TEST(CloudIo, LzfBackReferences) {
  // "abcabcabcab": literals "abc", then a back-reference of 8 bytes at distance 3 (overlapping its own output).
  const unsigned char in[] = {2, 'a', 'b', 'c', (6 << 5) | 0, 2};
  unsigned char out[11];
  tsdf_mcl::io::lzf_decompress(in, sizeof(in), out, sizeof(out), "test");
  EXPECT_EQ(std::string(reinterpret_cast<char*>(out), sizeof(out)), "abcabcabcab");
  const unsigned char before_start[] = {0, 'a', (1 << 5) | 0, 5};
  EXPECT_THROW(tsdf_mcl::io::lzf_decompress(before_start, sizeof(before_start), out, 4, "test"), tsdf_mcl::Error);
  EXPECT_THROW(tsdf_mcl::io::lzf_decompress(in, sizeof(in), out, 10, "test"), tsdf_mcl::Error);  // more than announced
  EXPECT_THROW(tsdf_mcl::io::lzf_decompress(in, 3, out, 11, "test"), tsdf_mcl::Error);           // cut short
}

TEST(CloudIo, PlyVertices) {
  TempDir dir;
  // ascii, an element before the vertices and faces after them (a mesh's vertices are points too).
  std::string ascii =
      "ply\nformat ascii 1.0\ncomment x\nelement camera 1\nproperty list uchar float k\n"
      "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n2 0.5 0.5\n";
  for (const Vector3f& p : kPoints)
    ascii += std::to_string(p.x()) + " " + std::to_string(p.y()) + " " + std::to_string(p.z()) + " 255\n";
  write_bytes(dir / "ascii.ply", ascii + "3 0 1 2\n");
  expect_points(tsdf_mcl::read_cloud(dir / "ascii.ply"));
  for (const bool big : {false, true}) {
    std::string ply = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                      " 1.0\nelement vertex 3\nproperty double x\nproperty float intensity\nproperty double y\n"
                      "property double z\nend_header\n";
    for (const Vector3f& p : kPoints) {
      put<double>(ply, p.x(), big);
      put<float>(ply, 1.0f, big);
      put<double>(ply, p.y(), big);
      put<double>(ply, p.z(), big);
    }
    write_bytes(dir / "binary.ply", ply);
    expect_points(tsdf_mcl::read_cloud(dir / "binary.ply"));
  }
}

TEST(CloudIo, HostileHeadersEndInOneError) {
  TempDir dir;
  const auto file = [&](const std::string& name, const std::string& bytes) {
    write_bytes(dir / name, bytes);
    return dir / name;
  };
  const std::string xyz = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  EXPECT_NE(expect_error(file("big.pcd", xyz + "POINTS 99999999999999999\nDATA binary\n")).find("PCD POINTS"),
            std::string::npos);
  EXPECT_NE(expect_error(file("short.pcd", xyz + "POINTS 1000\nDATA binary\n" + std::string(100, '\0')))
                .find("PCD data truncated"),
            std::string::npos);
  EXPECT_NE(expect_error(file("int.pcd",
                              "FIELDS x y z\nSIZE 4 4 4\nTYPE I I I\nPOINTS 1\nDATA binary\n" + std::string(12, '\0')))
                .find("float32 or float64"),
            std::string::npos);
  // A few bytes that claim a 4 GB payload, and one whose sizes disagree with the header.
  std::string bomb = xyz + "POINTS 357913941\nDATA binary_compressed\n";
  put<std::uint32_t>(bomb, 4);
  put<std::uint32_t>(bomb, 357913941u * 12u);
  EXPECT_NE(expect_error(file("bomb.pcd", bomb + "abcd")).find("LZF expands at most 88 times"), std::string::npos);
  std::string wrong = xyz + "POINTS 2\nDATA binary_compressed\n";
  put<std::uint32_t>(wrong, 4);
  put<std::uint32_t>(wrong, 12);
  EXPECT_NE(expect_error(file("wrong.pcd", wrong + "abcd")).find("need 24"), std::string::npos);
  EXPECT_NE(expect_error(file("nodata.pcd", xyz + "POINTS 2\n")).find("no DATA line"), std::string::npos);
  EXPECT_NE(expect_error(file("rows.ply",
                              "ply\nformat binary_little_endian 1.0\nelement vertex 1000000\nproperty float x\n"
                              "property float y\nproperty float z\nend_header\n" +
                                  std::string(24, '\0')))
                .find("truncated or corrupt"),
            std::string::npos);
  EXPECT_NE(
      expect_error(file("noxyz.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n"))
          .find("lack x, y or z"),
      std::string::npos);
  EXPECT_NE(expect_error(file("cut.ply",
                              "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                              "property float z\nend_header\n1 2 3\n4 5\n"))
                .find("truncated"),
            std::string::npos);
  EXPECT_NE(expect_error(file("header.ply", "ply\nformat ascii 1.0\nelement vertex 1\n")).find("end_header"),
            std::string::npos);
  EXPECT_NE(expect_error(file("cloud.xyz", "1 2 3\n")).find("unknown extension"), std::string::npos);

  // Through the command line: one line, no map.
  const std::string out = " -o '" + (dir / "m.tsdf").string() + "'";
  expect_one_line_error(dir, "build-map --cloud '" + (dir / "bomb.pcd").string() + "'" + out,
                        "LZF expands at most 88 times");
  expect_one_line_error(dir, "build-map --cloud '" + (dir / "rows.ply").string() + "'" + out, "truncated or corrupt");
  expect_one_line_error(dir, "build-map --cloud '" + (dir / "missing.pcd").string() + "'" + out, "does not exist");
  expect_one_line_error(dir, "build-map --mesh '" + (dir / "ok.pcd").string() + "' --trajectory x.tum" + out,
                        "applies to --dataset, --bag and --cloud only");
  tsdf_mcl::write_pcd(dir / "ok.pcd", kPoints);
  expect_one_line_error(
      dir,
      "build-map --cloud '" + (dir / "ok.pcd").string() + "' --trajectory '" + (dir / "none.tum").string() + "'" + out,
      "does not exist");
  expect_one_line_error(dir, "build-map --cloud '" + (dir / "ok.pcd").string() + "'" + out, "isolated");
  // Two dense patches 850 m apart: the box between them is past the budget.
  std::vector<Vector3f> far;
  for (const Vector3f& corner : {Vector3f(0, 0, 0), Vector3f(600, 600, 60)}) {
    for (int i = 0; i < 20; ++i)
      for (int j = 0; j < 20; ++j)
        far.push_back(corner + Vector3f(0.05f * static_cast<float>(i), 0.05f * static_cast<float>(j), 0.0f));
  }
  tsdf_mcl::write_pcd(dir / "far.pcd", far);
  expect_one_line_error(dir, "build-map --cloud '" + (dir / "far.pcd").string() + "' --voxel 0.1 --max_memory 64" + out,
                        "memory budget of 64 MiB");
  expect_one_line_error(dir, "export-cloud -o '" + (dir / "x.pcd").string() + "'", "missing --dataset");
  EXPECT_FALSE(std::filesystem::exists(dir / "m.tsdf"));
}

}  // namespace
