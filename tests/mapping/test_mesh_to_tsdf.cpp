#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"
#include "tsdf_mcl/io/mesh.hpp"

using Eigen::Vector3f;
using Eigen::Vector3i;
using tsdf_mcl::MeshMapOptions;
using tsdf_mcl::TriangleMesh;
using tsdf_mcl::TsdfMap;

namespace {

// Calls f(voxel) for every voxel of the map's block box.
template <typename F>
void for_each_voxel(const TsdfMap& map, F&& f) {
  const Vector3i lo = map.min_block() * TsdfMap::kBlockSize;
  const Vector3i hi = (map.min_block() + map.dims_blocks()) * TsdfMap::kBlockSize;
  for (int z = lo.z(); z < hi.z(); ++z)
    for (int y = lo.y(); y < hi.y(); ++y)
      for (int x = lo.x(); x < hi.x(); ++x) f(Vector3i(x, y, z));
}

float box_distance(const Vector3f& p, const Vector3f& lo, const Vector3f& hi) {
  const Vector3f c = 0.5f * (lo + hi), h = 0.5f * (hi - lo);
  const Vector3f q = (p - c).cwiseAbs() - h;
  return q.cwiseMax(0.0f).norm() + std::min(q.maxCoeff(), 0.0f);
}

// Checks every voxel against an analytic signed distance: band voxels known within `tol`, voxels beyond the band
// at +-truncation or (outside the band blocks) free / unknown on the right side.
template <typename Distance>
void check_against(const TsdfMap& map, Distance&& truth, float tol) {
  const float trunc = map.truncation();
  std::size_t band = 0, free_outside = 0;
  for_each_voxel(map, [&](const Vector3i& v) {
    const float d = truth(map.center_of(v));
    const std::optional<float> got = map.distance(v);
    if (std::abs(d) <= trunc) {
      ++band;
      ASSERT_TRUE(got.has_value()) << v.transpose() << " true " << d;
      ASSERT_NEAR(*got, d, tol) << v.transpose();
      return;
    }
    if (!got) {
      // Only the solid's inside may stay unknown.
      ASSERT_LT(d, 0.0f) << v.transpose();
      return;
    }
    ASSERT_TRUE(std::isfinite(*got));
    ASSERT_NEAR(*got, d > 0 ? trunc : -trunc, tol) << v.transpose() << " true " << d;
    free_outside += d > 0;
  });
  EXPECT_GT(band, 1000u);
  EXPECT_GT(free_outside, 1000u);
}

}  // namespace

TEST(MeshToTsdf, BoxMatchesAnalyticDistances) {
  // Corners off the voxel grid, so that band voxels see all kinds of distances.
  const Vector3f lo(-1.51f, -1.23f, -1.02f), hi(1.47f, 1.31f, 0.99f);
  MeshMapOptions options;
  options.voxel_size = 0.05f;
  options.truncation = 0.2f;
  std::size_t calls = 0, last_done = 0, last_total = 0;
  const TsdfMap map = tsdf_mcl::build_map_from_mesh(tsdf_mcl::test::box_mesh(lo, hi), options,
                                                    [&](std::size_t done, std::size_t total) {
                                                      ++calls;
                                                      last_done = done;
                                                      last_total = total;
                                                    });
  EXPECT_GT(calls, 0u);
  EXPECT_EQ(last_done, last_total);
  // Distances at voxel centres are exact: only float rounding and the quantization remain.
  check_against(
      map, [&](const Vector3f& p) { return box_distance(p, lo, hi); }, 1e-4f + map.quantization_step());

  const TsdfMap::Stats s = map.stats();
  EXPECT_GT(s.free_blocks, 0u);
  // Free blocks lie outside the box, and the box's core (more than the truncation inside) is not free.
  for_each_voxel(map, [&](const Vector3i& v) {
    if (map.block_entry(TsdfMap::block_of(v)) == TsdfMap::kFreeBlock) {
      ASSERT_GT(box_distance(map.center_of(v), lo, hi), 0.0f);
    }
  });
  EXPECT_FALSE(map.nearest(Vector3f(0, 0, 0)).known);
  const auto outside = map.nearest(Vector3f(2.3f, 0, 0));
  ASSERT_TRUE(outside.known);
  EXPECT_FLOAT_EQ(outside.distance, options.truncation);
}

TEST(MeshToTsdf, SphereMatchesAnalyticDistances) {
  const Vector3f c(0.013f, -0.021f, 0.007f);
  const float r = 1.0f;
  const TriangleMesh sphere = tsdf_mcl::test::icosphere(c, r, 4);
  // The mesh is inscribed in the sphere: it deviates by at most r minus the smallest distance from the centre to
  // a face plane.
  float deepest = r;
  for (const Vector3i& t : sphere.triangles) {
    const Vector3f& a = sphere.vertices[static_cast<std::size_t>(t[0])];
    const Vector3f n = (sphere.vertices[static_cast<std::size_t>(t[1])] - a)
                           .cross(sphere.vertices[static_cast<std::size_t>(t[2])] - a)
                           .normalized();
    deepest = std::min(deepest, std::abs(n.dot(a - c)));
  }
  const float sagitta = r - deepest;
  ASSERT_LT(sagitta, 0.002f);
  MeshMapOptions options;
  options.voxel_size = 0.05f;
  options.truncation = 0.15f;
  const TsdfMap map = tsdf_mcl::build_map_from_mesh(sphere, options);
  check_against(
      map, [&](const Vector3f& p) { return (p - c).norm() - r; }, sagitta + 1e-4f + map.quantization_step());
  EXPECT_GT(map.stats().free_blocks, 0u);
  EXPECT_FALSE(map.nearest(c).known);
}

TEST(MeshToTsdf, OpenSurfaceWithoutFreeSpaceFill) {
  // A single square: not a closed solid. Band voxels are signed by the face normal (+z), nothing else is known.
  TriangleMesh quad;
  quad.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  quad.triangles = {{0, 1, 2}, {0, 2, 3}};
  MeshMapOptions options;
  options.voxel_size = 0.1f;
  options.truncation = 0.3f;
  options.fill_free_space = false;
  const TsdfMap map = tsdf_mcl::build_map_from_mesh(quad, options);
  EXPECT_NEAR(*map.distance({5, 5, 2}), 0.2f, 1e-4f);
  EXPECT_NEAR(*map.distance({5, 5, -1}), -0.1f, 1e-4f);
  EXPECT_EQ(map.stats().free_blocks, 0u);
  EXPECT_FALSE(map.distance({5, 5, 12}).has_value());
}

TEST(MeshToTsdf, RejectsBadInput) {
  const TriangleMesh box = tsdf_mcl::test::box_mesh(Vector3f(0, 0, 0), Vector3f(1, 1, 1));
  MeshMapOptions bad_voxel;
  bad_voxel.voxel_size = 0.0f;
  EXPECT_THROW(tsdf_mcl::build_map_from_mesh(box, bad_voxel), tsdf_mcl::Error);
  MeshMapOptions bad_trunc;
  bad_trunc.truncation = 0.01f;
  EXPECT_THROW(tsdf_mcl::build_map_from_mesh(box, bad_trunc), tsdf_mcl::Error);
  EXPECT_THROW(tsdf_mcl::build_map_from_mesh(TriangleMesh{}, MeshMapOptions{}), tsdf_mcl::Error);
  TriangleMesh broken = box;
  broken.triangles.emplace_back(0, 1, 99);
  EXPECT_THROW(tsdf_mcl::build_map_from_mesh(broken, MeshMapOptions{}), tsdf_mcl::Error);
}

TEST(MeshToTsdf, AvzBuildingIsFreeInRoomsAndAboveTheWalls) {
  const auto file = tsdf_mcl::test::shared_data() / "avz" / "avz_no_roof.stl";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "shared data not found: " << file;
  MeshMapOptions options;
  options.voxel_size = 0.1f;
  options.truncation = 0.3f;
  const TsdfMap map = tsdf_mcl::build_map_from_mesh(tsdf_mcl::load_mesh(file), options);
  // Rooms and corridors at 1 m height (read off a slice of the map), and the open sky above the roofless floor.
  const Vector3f free_points[] = {{-4.25f, 6.45f, 1.0f}, {-0.5f, -4.05f, 1.0f}, {-12.0f, -29.0f, 1.0f},
                                  {5.5f, 0.98f, 1.0f},   {-5.0f, 0.0f, 4.7f},   {8.0f, -30.0f, 4.7f}};
  for (const Vector3f& p : free_points) {
    const auto s = map.nearest(p);
    ASSERT_TRUE(s.known) << p.transpose();
    EXPECT_GT(s.distance, 0.0f) << p.transpose();
  }
  std::size_t negative = 0;
  for (std::size_t w = 0; w < map.block_pool().size(); ++w) {
    for (const std::uint32_t half : {map.block_pool()[w] & 0xFFFFu, map.block_pool()[w] >> 16}) {
      const auto q = static_cast<std::int16_t>(half);
      negative += q < 0 && q != TsdfMap::kUnknownValue;
    }
  }
  EXPECT_GT(negative, 10000u);  // inside the walls
  // Free space: at least the rooms (a floor of about 1300 m^2, 3 m high), at most the whole map box.
  const TsdfMap::Stats s = map.stats();
  const Vector3f size = map.world_max() - map.world_min();
  const double free_m3 = static_cast<double>(s.free_voxels) * 1e-3;
  EXPECT_GT(free_m3, 3000.0);
  EXPECT_LT(free_m3, static_cast<double>(size.prod()));
}
