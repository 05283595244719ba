#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/mesh.hpp"

using Eigen::Vector3f;
using Eigen::Vector3i;
using tsdf_mcl::Error;
using tsdf_mcl::TriangleMesh;
using tsdf_mcl::test::TempDir;
using tsdf_mcl::test::write_bytes;

namespace {

// Two triangles sharing an edge: a unit square in the z = 0.5 plane.
const Vector3f kQuad[4] = {{0, 0, 0.5f}, {1, 0, 0.5f}, {1, 1, 0.5f}, {0, 1, 0.5f}};

template <typename T>
void put(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

template <typename T>
void put_be(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  for (std::size_t i = sizeof(T); i-- > 0;) out.push_back(bytes[i]);
}

std::string binary_stl(const std::vector<std::array<Vector3f, 3>>& triangles, const std::string& header_text) {
  std::string out = header_text;
  out.resize(80, ' ');
  put(out, static_cast<std::uint32_t>(triangles.size()));
  for (const auto& t : triangles) {
    for (int k = 0; k < 3; ++k) put(out, 0.0f);
    for (const auto& v : t)
      for (int a = 0; a < 3; ++a) put(out, v[a]);
    put(out, std::uint16_t{0});
  }
  return out;
}

const std::vector<std::array<Vector3f, 3>> kQuadTriangles = {{kQuad[0], kQuad[1], kQuad[2]},
                                                             {kQuad[0], kQuad[2], kQuad[3]}};

// The quad loaded from any format: 4 distinct vertices, 2 triangles, corners in the right order.
void expect_quad(const TriangleMesh& m) {
  ASSERT_EQ(m.vertices.size(), 4u);
  ASSERT_EQ(m.triangles.size(), 2u);
  for (int t = 0; t < 2; ++t) {
    for (int k = 0; k < 3; ++k) {
      const int i = m.triangles[static_cast<std::size_t>(t)][k];
      ASSERT_GE(i, 0);
      ASSERT_LT(i, 4);
      EXPECT_EQ(m.vertices[static_cast<std::size_t>(i)],
                kQuadTriangles[static_cast<std::size_t>(t)][static_cast<std::size_t>(k)]);
    }
  }
}

void expect_error(const std::filesystem::path& file, const std::string& words) {
  try {
    tsdf_mcl::load_mesh(file);
    FAIL() << "no error for " << file;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file.filename().string()), std::string::npos) << what;
    EXPECT_NE(what.find(words), std::string::npos) << "'" << what << "' lacks '" << words << "'";
  }
}

}  // namespace

TEST(MeshIo, BinaryStlMergesDuplicateVertices) {
  TempDir dir;
  // The header starts with "solid", as some exporters write it: the size rule must still pick binary.
  write_bytes(dir / "quad.stl", binary_stl(kQuadTriangles, "solid exported by a binary writer"));
  expect_quad(tsdf_mcl::load_mesh(dir / "quad.stl"));
}

TEST(MeshIo, AsciiStl) {
  TempDir dir;
  std::string text = "solid my quad\n";
  for (const auto& t : kQuadTriangles) {
    text += "  facet normal 0 0 1\n    outer loop\n";
    for (const auto& v : t)
      text +=
          "      vertex " + std::to_string(v.x()) + " " + std::to_string(v.y()) + " " + std::to_string(v.z()) + "\n";
    text += "    endloop\n  endfacet\n";
  }
  write_bytes(dir / "quad.STL", text + "endsolid my quad\n");
  expect_quad(tsdf_mcl::load_mesh(dir / "quad.STL"));

  write_bytes(dir / "cut.stl", text.substr(0, text.size() - 40));
  expect_error(dir / "cut.stl", "truncated");
  write_bytes(dir / "bad.stl", "solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 zero\n");
  expect_error(dir / "bad.stl", "expected a number");
  write_bytes(dir / "nan.stl",
              "solid x\n facet normal 0 0 1\n outer loop\n vertex 0 0 nan\n vertex 1 0 0\n vertex 0 1 0\n endloop\n "
              "endfacet\nendsolid\n");
  expect_error(dir / "nan.stl", "non-finite");
}

TEST(MeshIo, BinaryStlErrors) {
  TempDir dir;
  std::string good = binary_stl(kQuadTriangles, "binary");
  write_bytes(dir / "cut.stl", good.substr(0, good.size() - 7));
  expect_error(dir / "cut.stl", "truncated");
  write_bytes(dir / "short.stl", good.substr(0, 40));
  expect_error(dir / "short.stl", "too short");
  write_bytes(dir / "empty.stl", "");
  expect_error(dir / "empty.stl", "empty file");
  write_bytes(dir / "none.stl", binary_stl({}, "binary"));
  expect_error(dir / "none.stl", "no triangles");
  std::string nan = good;
  const float q = std::nanf("");
  std::memcpy(nan.data() + 84 + 12, &q, 4);
  write_bytes(dir / "nan.stl", nan);
  expect_error(dir / "nan.stl", "non-finite");
  expect_error(dir / "missing.stl", "does not exist");
  write_bytes(dir / "quad.xyz", good);
  expect_error(dir / "quad.xyz", "unknown extension");
}

TEST(MeshIo, AsciiPlyWithExtraPropertiesAndPolygons) {
  TempDir dir;
  // A quad face, extra vertex properties (normals, colour) and an extra element with a list: all must be skipped.
  const std::string ply =
      "ply\nformat ascii 1.0\ncomment test\nelement vertex 4\nproperty double x\nproperty float nx\n"
      "property double y\nproperty double z\nproperty uchar red\nelement face 1\n"
      "property uchar flags\nproperty list uchar int vertex_indices\nelement edge 1\n"
      "property list int int ends\nend_header\n"
      "0 9 0 0.5 255\n1 9 0 0.5 0\n1 9 1 0.5 0\n0 9 1 0.5 0\n"
      "7 4 0 1 2 3\n2 0 1\n";
  write_bytes(dir / "quad.ply", ply);
  expect_quad(tsdf_mcl::load_mesh(dir / "quad.ply"));

  write_bytes(dir / "cut.ply", ply.substr(0, ply.find("7 4")));
  expect_error(dir / "cut.ply", "truncated");
  std::string out_of_range = ply;
  out_of_range.replace(out_of_range.find("7 4 0 1 2 3"), 11, "7 4 0 1 2 9");
  write_bytes(dir / "range.ply", out_of_range);
  expect_error(dir / "range.ply", "out of range");
  write_bytes(dir / "noheader.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n");
  expect_error(dir / "noheader.ply", "end_header");
  write_bytes(dir / "notply.ply", "solid\n");
  expect_error(dir / "notply.ply", "not a PLY");
  write_bytes(dir / "points.ply",
              "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float "
              "z\nend_header\n0 0 0\n");
  expect_error(dir / "points.ply", "no face element");
}

TEST(MeshIo, BinaryPlyBothEndians) {
  TempDir dir;
  for (const bool big : {false, true}) {
    std::string ply = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                      " 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                      "property short extra\nelement face 2\nproperty list uchar uint vertex_indices\nend_header\n";
    for (const auto& v : kQuad) {
      for (int a = 0; a < 3; ++a) big ? put_be(ply, v[a]) : put(ply, v[a]);
      big ? put_be(ply, std::int16_t{-3}) : put(ply, std::int16_t{-3});
    }
    for (const Vector3i& t : {Vector3i(0, 1, 2), Vector3i(0, 2, 3)}) {
      ply.push_back(3);
      for (int a = 0; a < 3; ++a)
        big ? put_be(ply, static_cast<std::uint32_t>(t[a])) : put(ply, static_cast<std::uint32_t>(t[a]));
    }
    const auto file = dir / (big ? "be.ply" : "le.ply");
    write_bytes(file, ply);
    expect_quad(tsdf_mcl::load_mesh(file));
    write_bytes(dir / "cut.ply", ply.substr(0, ply.size() - 3));
    expect_error(dir / "cut.ply", "truncated");
  }
}

TEST(MeshIo, ObjIndexForms) {
  TempDir dir;
  // Mixed v, v/vt, v//vn, v/vt/vn and negative indices; a quad as a fan.
  const std::string obj =
      "# comment\nmtllib x.mtl\no quad\nv 0 0 0.5\nv 1 0 0.5\nv 1 1 0.5\nv 0 1 0.5 1.0\nvt 0 0\nvn 0 0 1\n"
      "s off\nf 1/1 2//1 -2/1/1 4\n";
  write_bytes(dir / "quad.obj", obj);
  expect_quad(tsdf_mcl::load_mesh(dir / "quad.obj"));

  write_bytes(dir / "range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n");
  expect_error(dir / "range.obj", "out of range");
  write_bytes(dir / "neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n");
  expect_error(dir / "neg.obj", "before the first vertex");
  write_bytes(dir / "zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n");
  expect_error(dir / "zero.obj", "malformed OBJ face");
  write_bytes(dir / "badv.obj", "v 0 0\nf 1 1 1\n");
  expect_error(dir / "badv.obj", "malformed OBJ vertex");
  write_bytes(dir / "nan.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_error(dir / "nan.obj", "non-finite");
  write_bytes(dir / "noface.obj", "v 0 0 0\n");
  expect_error(dir / "noface.obj", "no triangles");
}

TEST(MeshIo, SavePlyRoundTripAndAppend) {
  TempDir dir;
  TriangleMesh a = tsdf_mcl::test::box_mesh(Vector3f(-1, -2, -3), Vector3f(1, 2, 3));
  const TriangleMesh b = tsdf_mcl::test::icosphere(Vector3f(5, 0, 0), 1.0f, 1);
  a.append(b);
  ASSERT_EQ(a.vertices.size(), 8u + b.vertices.size());
  EXPECT_EQ(a.triangles.back(), Vector3i(b.triangles.back().array() + 8));
  EXPECT_TRUE(a.min_corner().isApprox(Vector3f(-1, -2, -3)));
  EXPECT_TRUE(a.max_corner().isApprox(Vector3f(6, 2, 3)));

  tsdf_mcl::save_mesh_ply(a, dir / "out.ply");
  const TriangleMesh c = tsdf_mcl::load_mesh(dir / "out.ply");
  EXPECT_EQ(c.vertices, a.vertices);
  EXPECT_EQ(c.triangles, a.triangles);
}

TEST(MeshIo, LoadsTheAvzMesh) {
  const auto file = tsdf_mcl::test::shared_data() / "avz" / "avz_no_roof.stl";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "shared data not found: " << file;
  const TriangleMesh m = tsdf_mcl::load_mesh(file);
  EXPECT_EQ(m.triangles.size(), 11104u);
  // Indexed: far fewer vertices than 3 per triangle.
  EXPECT_LT(m.vertices.size(), m.triangles.size() * 3 / 2);
  EXPECT_NEAR(m.min_corner().x(), -16.9f, 0.1f);
  EXPECT_NEAR(m.max_corner().y(), 14.6f, 0.1f);
}
