#include <gtest/gtest.h>

#include <algorithm>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"
#include "tsdf_mcl/map/map_surface.hpp"

namespace tsdf_mcl {
namespace {

// map_surface (the ROS node's ~map_cloud): the voxels at the walls of a box room, none in free space, thinned on
// request.
TEST(MapSurface, PointsLieOnTheSurfacesAndThinAsAsked) {
  const TsdfMap map = build_map_from_mesh(test::box_mesh({0.0f, 0.0f, 0.0f}, {4.0f, 3.0f, 2.5f}), [] {
    MeshMapOptions o;
    o.voxel_size = 0.1f;
    return o;
  }());
  const PointCloud all = map_surface(map, 0);
  ASSERT_GT(all.points.size(), 1000u);
  for (const Eigen::Vector3f& p : all.points) {
    const Eigen::Vector3f lo = p.cwiseAbs(), hi = (Eigen::Vector3f(4.0f, 3.0f, 2.5f) - p).cwiseAbs();
    EXPECT_LE(std::min(lo.minCoeff(), hi.minCoeff()), 0.1f) << p.transpose();  // within a voxel of a wall
  }
  const PointCloud thinned = map_surface(map, 500);
  EXPECT_LE(thinned.points.size(), 500u);
  EXPECT_GE(thinned.points.size(), 250u);
  EXPECT_EQ(thinned.points.front(), all.points.front());
}

}  // namespace
}  // namespace tsdf_mcl
