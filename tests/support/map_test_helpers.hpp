#pragma once
// Helpers shared by the map-building tests: a self-deleting temporary folder, raw file writing, the path to the
// data beside the project, analytic meshes.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>
#include <utility>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/mesh.hpp"
#include "checkout_paths.hpp"

namespace tsdf_mcl::test {

class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = "tsdf_mcl_";
    if (info) name += std::string(info->test_suite_name()) + "_" + info->name();
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

inline void write_bytes(const std::filesystem::path& file, const std::string& bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string read_bytes(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

inline std::filesystem::path shared_data() { return shared_data_dir(); }

// Bit-by-bit CRC-32 (IEEE), independent of the table-driven one in the library: tests re-seal edited map files.
inline std::uint32_t crc32_bitwise(const std::string& bytes) {
  std::uint32_t c = 0xFFFFFFFFu;
  for (unsigned char b : bytes) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
  }
  return ~c;
}

inline void put_u32(std::string& bytes, std::size_t offset, std::uint32_t value) {
  for (int k = 0; k < 4; ++k)
    bytes[offset + static_cast<std::size_t>(k)] = static_cast<char>((value >> (8 * k)) & 0xFFu);
}

// Binary STL of a mesh (normals left zero, as many exporters do).
inline void write_binary_stl(const TriangleMesh& mesh, const std::filesystem::path& file) {
  std::string out(80, ' ');
  auto put = [&out](auto value) { out.append(reinterpret_cast<const char*>(&value), sizeof(value)); };
  put(static_cast<std::uint32_t>(mesh.triangles.size()));
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) put(0.0f);
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) put(mesh.vertices[static_cast<std::size_t>(t[k])][a]);
    put(std::uint16_t{0});
  }
  write_bytes(file, out);
}

// Axis-aligned box [lo, hi] with outward normals (counter-clockwise seen from outside).
inline TriangleMesh box_mesh(const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) {
    m.vertices.emplace_back((i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z());
  }
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.emplace_back(q[0], q[1], q[2]);
    m.triangles.emplace_back(q[0], q[2], q[3]);
  }
  return m;
}

// Icosphere: an icosahedron subdivided `levels` times, vertices projected onto the sphere; outward normals.
inline TriangleMesh icosphere(const Eigen::Vector3f& center, float radius, int levels) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  std::vector<Eigen::Vector3f> v = {{-1, t, 0},  {1, t, 0},  {-1, -t, 0}, {1, -t, 0}, {0, -1, t},  {0, 1, t},
                                    {0, -1, -t}, {0, 1, -t}, {t, 0, -1},  {t, 0, 1},  {-t, 0, -1}, {-t, 0, 1}};
  for (auto& p : v) p.normalize();
  std::vector<Eigen::Vector3i> f = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                                    {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                                    {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int, int>, int> midpoint;
    auto mid = [&](int a, int b) {
      const auto key = std::minmax(a, b);
      auto it = midpoint.find(key);
      if (it != midpoint.end()) return it->second;
      v.push_back((v[static_cast<std::size_t>(a)] + v[static_cast<std::size_t>(b)]).normalized());
      const int index = static_cast<int>(v.size()) - 1;
      midpoint.emplace(key, index);
      return index;
    };
    std::vector<Eigen::Vector3i> next;
    for (const auto& tri : f) {
      const int a = mid(tri[0], tri[1]), b = mid(tri[1], tri[2]), c = mid(tri[2], tri[0]);
      next.emplace_back(tri[0], a, c);
      next.emplace_back(tri[1], b, a);
      next.emplace_back(tri[2], c, b);
      next.emplace_back(a, b, c);
    }
    f = std::move(next);
  }
  TriangleMesh m;
  for (const auto& p : v) m.vertices.push_back(center + radius * p);
  m.triangles = std::move(f);
  return m;
}

// Reading `file` with `read` must throw one line that names the file and contains `words`.
template <typename ReadFn>
void expect_file_error(const std::filesystem::path& file, const std::string& words, ReadFn read) {
  try {
    read(file);
    ADD_FAILURE() << "no error for " << file;
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file.string()), std::string::npos) << what;
    EXPECT_NE(what.find(words), std::string::npos) << "'" << what << "' lacks '" << words << "'";
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

}  // namespace tsdf_mcl::test
