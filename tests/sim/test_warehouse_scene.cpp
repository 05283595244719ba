#include <gtest/gtest.h>

#include <cmath>

#include "tsdf_mcl/sim/route.hpp"
#include "tsdf_mcl/sim/traversability.hpp"
#include "sim_test_helpers.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

using tsdf_mcl::PointCloud;
using tsdf_mcl::Pose;
using tsdf_mcl::TriangleMesh;
using tsdf_mcl::sim::RayCaster;
using tsdf_mcl::sim::TraversabilityGrid;

namespace {

using Warehouse = tsdf_mcl::test::SceneOnGrid;

const Warehouse& warehouse() {
  static const Warehouse w(tsdf_mcl::sim::warehouse_scene(1));
  return w;
}

bool free_at(const TraversabilityGrid& grid, double x, double y) {
  const int i = grid.index_of(Eigen::Vector2d(x, y));
  return i >= 0 && grid.free(i);
}

// Centres of the seven aisles between the fourteen rack rows, and of the rows' depths.
constexpr double kAisles[] = {3.2, 8.8, 14.4, 20.0, 25.6, 31.2, 36.8};
constexpr double kRacks[] = {1.05,  5.35,  6.65,  10.95, 12.25, 16.55, 17.85,
                             22.15, 23.45, 27.75, 29.05, 33.35, 34.65, 38.95};

}  // namespace

TEST(SimWarehouse, SeedFillsTheRacksTheHallStays) {
  const TriangleMesh& a = warehouse().mesh;
  const TriangleMesh again = tsdf_mcl::sim::warehouse_scene(1);
  EXPECT_EQ(a.vertices, again.vertices);
  EXPECT_EQ(a.triangles, again.triangles);
  const TriangleMesh other = tsdf_mcl::sim::warehouse_scene(2);
  EXPECT_NE(a.triangles.size(), other.triangles.size());
  EXPECT_TRUE(a.min_corner().isApprox(other.min_corner()) && a.max_corner().isApprox(other.max_corner()));
  // 40 x 25 m inside, 0.3 m walls and slabs, 7 m to the roof slab.
  EXPECT_NEAR(a.max_corner().x() - a.min_corner().x(), 40.6f, 1e-4f);
  EXPECT_NEAR(a.max_corner().y() - a.min_corner().y(), 25.6f, 1e-4f);
  EXPECT_NEAR(a.max_corner().z() - a.min_corner().z(), 7.6f, 1e-4f);
}

TEST(SimWarehouse, ClosedWithOutwardNormals) {
  tsdf_mcl::test::expect_closed_with_outward_normals(
      warehouse().mesh,
      Eigen::AlignedBox3f(Eigen::Vector3f(-0.31f, -0.31f, -0.31f), Eigen::Vector3f(40.31f, 25.31f, 7.31f)), 6.0f);
}

// The robot drives in every aisle, the cross aisle and the dock area, never into a rack.
TEST(SimWarehouse, AislesAreTraversableRacksAreNot) {
  const TraversabilityGrid& grid = warehouse().grid;
  for (double x : kAisles) {
    for (double y : {9.0, 15.0, 21.0}) EXPECT_TRUE(free_at(grid, x, y)) << x << ", " << y;
  }
  for (double x : kRacks) {
    for (double y = 8.2; y < 22.0; y += 0.3) EXPECT_FALSE(free_at(grid, x, y)) << x << ", " << y;
  }
  EXPECT_TRUE(free_at(grid, 20.0, 23.5));  // cross aisle
  EXPECT_TRUE(free_at(grid, 16.0, 2.0));   // in front of a dock door
  // Aisles, cross aisle and dock area, less pallets, columns and clearance.
  EXPECT_GT(grid.free_area(), 450.0);
  EXPECT_LT(grid.free_area(), 700.0);
  EXPECT_TRUE(tsdf_mcl::sim::find_ramps(grid).empty());
}

// From an aisle the LiDAR sees the racks beside it and, through empty slots and between loads, the racks
// behind them; the dock doors sit in recesses of the south wall.
TEST(SimWarehouse, LidarSeesThroughTheRacks) {
  const Warehouse& w = warehouse();
  const tsdf_mcl::sim::LidarModel lidar = tsdf_mcl::sim::LidarModel::os0_64();
  const Pose in_aisle = tsdf_mcl::pose_from_xyz_rpy(kAisles[3], 15.0, 0.5, 0.0, 0.0, M_PI / 2);
  const PointCloud cloud = tsdf_mcl::sim::simulate_scan(w.scene, lidar, in_aisle, in_aisle, {0.0, 0.0}, 1);
  ASSERT_EQ(cloud.size(), lidar.rays());  // closed: every ray returns
  std::size_t near_racks = 0, beyond = 0;
  for (const auto& p : cloud.points) {
    const Eigen::Vector3d q = in_aisle * p.cast<double>();
    if (q.y() < 8.0 || q.y() > 22.0) continue;
    const double across = std::abs(q.x() - kAisles[3]);
    near_racks += across > 1.5 && across < 4.1;  // the two back-to-back rows on either side
    beyond += across > 4.3 && q.z() > 0.05;      // past them
  }
  EXPECT_GT(near_racks, 10000u);
  EXPECT_GT(beyond, 500u);
  // The roller doors are 0.22 m behind the wall's inner face.
  const RayCaster::Hit door = w.scene.cast(Eigen::Vector3f(16.0f, 2.0f, 1.0f), Eigen::Vector3f(0, -1, 0), 10.0f);
  const RayCaster::Hit wall = w.scene.cast(Eigen::Vector3f(12.0f, 2.0f, 1.0f), Eigen::Vector3f(0, -1, 0), 10.0f);
  EXPECT_NEAR(door.distance - wall.distance, 0.22f, 1e-4f);
}

TEST(SimWarehouse, TestRoutesDriveTheAisles) {
  const Warehouse& w = warehouse();
  for (std::uint64_t seed : {1u, 2u}) {
    const tsdf_mcl::sim::Route route =
        tsdf_mcl::sim::plan_route(w.grid, w.scene, w.robot, tsdf_mcl::sim::RouteKind::test, seed, 40.0);
    EXPECT_GT(route.length(), 40.0);
    int in_aisles = 0;
    for (const auto& s : route.samples()) {
      const Eigen::Vector3d p = s.world_T_base.translation();
      EXPECT_NEAR(p.z(), 0.0, 1e-3);
      in_aisles += p.y() > 9.0 && p.y() < 21.0;
    }
    EXPECT_GT(in_aisles, 0) << "seed " << seed;
  }
}
