#include <gtest/gtest.h>

#include <cmath>

#include "tsdf_mcl/sim/route.hpp"
#include "tsdf_mcl/sim/traversability.hpp"
#include "sim_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

using tsdf_mcl::TriangleMesh;
using tsdf_mcl::sim::RayCaster;
using tsdf_mcl::sim::RobotModel;
using tsdf_mcl::sim::Route;
using tsdf_mcl::sim::RouteKind;
using tsdf_mcl::sim::TraversabilityGrid;

namespace {

using Office = tsdf_mcl::test::SceneOnGrid;

const Office& office() { return tsdf_mcl::test::office_on_grid(); }

// Distance from the base to the nearest surface at a few heights between a step and the robot's height.
double clearance_at(const RayCaster& scene, const tsdf_mcl::Pose& base) {
  double nearest = std::numeric_limits<double>::infinity();
  for (double h : {0.1, 0.5, 0.9}) {
    const Eigen::Vector3f origin = (base * Eigen::Vector3d(0, 0, h)).cast<float>();
    for (int k = 0; k < 36; ++k) {
      const double a = 2.0 * M_PI * k / 36.0;
      const Eigen::Vector3f d = (base.linear() * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0)).cast<float>();
      const RayCaster::Hit hit = scene.cast(origin, d, 5.0f);
      if (hit.hit()) nearest = std::min(nearest, static_cast<double>(hit.distance));
    }
  }
  return nearest;
}

}  // namespace

TEST(SimRoute, TestRoutesKeepClearAndDriveOverARamp) {
  const Office& o = office();
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const Route route =
        tsdf_mcl::sim::plan_route(o.grid, o.scene, o.robot, RouteKind::test, seed, 25.0).truncated(0.0, 25.0);
    EXPECT_NEAR(route.length(), 25.0, 0.1) << "seed " << seed;
    double max_pitch = 0.0, lowest = 1e9, highest = -1e9, worst_clearance = 1e9, worst_floor_gap = 0.0;
    double max_speed = 0.0;
    const auto& samples = route.samples();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      const tsdf_mcl::Pose& base = samples[i].world_T_base;
      const Eigen::Vector3d rpy = tsdf_mcl::rpy_of(base.linear());
      max_pitch = std::max(max_pitch, std::abs(rpy.y()));
      lowest = std::min(lowest, base.translation().z());
      highest = std::max(highest, base.translation().z());
      if (i % 4 == 0) worst_clearance = std::min(worst_clearance, clearance_at(o.scene, base));
      // The base sits on the floor.
      const RayCaster::Hit down =
          o.scene.cast((base * Eigen::Vector3d(0, 0, 0.2)).cast<float>(), Eigen::Vector3f(0, 0, -1), 1.0f);
      ASSERT_TRUE(down.hit());
      worst_floor_gap = std::max(worst_floor_gap, std::abs(down.distance - 0.2 / std::cos(rpy.y())));
      if (i > 0 && samples[i].time > samples[i - 1].time) {
        max_speed = std::max(max_speed,
                             (samples[i].distance - samples[i - 1].distance) / (samples[i].time - samples[i - 1].time));
      }
    }
    // The robot's radius (0.3 m) less half a grid cell's diagonal.
    EXPECT_GT(worst_clearance, 0.25) << "seed " << seed;
    EXPECT_GT(max_pitch * 180.0 / M_PI, 6.0) << "seed " << seed;  // on a 7-8.5 deg ramp
    EXPECT_GT(highest - lowest, 0.4) << "seed " << seed;
    EXPECT_LT(worst_floor_gap, 0.03) << "seed " << seed;
    EXPECT_LE(max_speed, o.robot.speed + 1e-6) << "seed " << seed;
    EXPECT_DOUBLE_EQ(samples.front().time, 0.0);
  }
}

TEST(SimRoute, SeedsChooseRoutes) {
  const Office& o = office();
  const auto plan = [&](std::uint64_t seed) {
    return tsdf_mcl::sim::plan_route(o.grid, o.scene, o.robot, RouteKind::test, seed, 20.0);
  };
  const Route a = plan(5), b = plan(5), c = plan(6);
  ASSERT_EQ(a.samples().size(), b.samples().size());
  for (std::size_t i = 0; i < a.samples().size(); ++i) {
    ASSERT_TRUE(a.samples()[i].world_T_base.isApprox(b.samples()[i].world_T_base, 0.0));
  }
  EXPECT_GT(
      (a.waypoints().front() - c.waypoints().front()).norm() + (a.waypoints().back() - c.waypoints().back()).norm(),
      1.0);
}

TEST(SimRoute, MappingRouteCoversTheFloor) {
  const Office& o = office();
  const Route route = tsdf_mcl::sim::plan_route(o.grid, o.scene, o.robot, RouteKind::mapping, 1, 0.0);
  const auto& cells = o.grid.free_cells();
  double worst = 0.0;
  for (std::size_t k = 0; k < cells.size(); k += 13) {
    const Eigen::Vector2d c = o.grid.center(cells[k]);
    double nearest = 1e9;
    for (std::size_t i = 0; i < route.samples().size(); i += 4) {
      nearest = std::min(nearest, (route.samples()[i].world_T_base.translation().head<2>() - c).norm());
    }
    worst = std::max(worst, nearest);
  }
  EXPECT_LT(worst, 4.6);  // the coverage radius of the waypoints
  EXPECT_GT(route.length(), 150.0);
  EXPECT_LT(route.length(), 900.0);
}

TEST(SimRoute, BasePoseInterpolatesAndClamps) {
  const Office& o = office();
  const Route route = tsdf_mcl::sim::plan_route(o.grid, o.scene, o.robot, RouteKind::test, 1, 10.0);
  const auto& s = route.samples();
  EXPECT_TRUE(route.base_pose(-1.0).isApprox(s.front().world_T_base));
  EXPECT_TRUE(route.base_pose(route.duration() + 5.0).isApprox(s.back().world_T_base));
  const std::size_t i = s.size() / 2;
  const double t = 0.5 * (s[i].time + s[i + 1].time);
  const Eigen::Vector3d mid = 0.5 * (s[i].world_T_base.translation() + s[i + 1].world_T_base.translation());
  EXPECT_LT((route.base_pose(t).translation() - mid).norm(), 1e-9);
}

TEST(SimRoute, MeshWithoutFloorIsRejected) {
  // A single wall: nothing to drive on.
  TriangleMesh wall;
  wall.vertices = {{0, 0, 0}, {5, 0, 0}, {5, 0, 3}, {0, 0, 3}};
  wall.triangles = {{0, 1, 2}, {0, 2, 3}};
  const RayCaster scene(wall);
  try {
    const TraversabilityGrid grid(scene, wall, RobotModel{});
    FAIL() << "expected an error";
  } catch (const tsdf_mcl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("no traversable floor"), std::string::npos) << e.what();
  }
}

TEST(SimRoute, AvzBuildingHasARouteIndoors) {
  const auto file = tsdf_mcl::test::shared_data() / "avz" / "avz_no_roof.stl";
  if (!std::filesystem::exists(file)) GTEST_SKIP() << "shared data " << file << " is not available";
  TriangleMesh mesh = tsdf_mcl::load_mesh(file);
  // The mesh has floors only in its two octagonal halls; with a ground plane the whole building opens up.
  const RayCaster building(mesh);
  EXPECT_GT(TraversabilityGrid(building, mesh, RobotModel{}).free_area(), 20.0);
  const Eigen::Vector3f lo = mesh.min_corner(), hi = mesh.max_corner();
  TriangleMesh ground = tsdf_mcl::test::box_mesh(Eigen::Vector3f(lo.x() - 0.5f, lo.y() - 0.5f, -0.1f),
                                                 Eigen::Vector3f(hi.x() + 0.5f, hi.y() + 0.5f, 0.0f));
  mesh.append(ground);
  const RayCaster scene(mesh);
  const RobotModel robot;
  const TraversabilityGrid grid(scene, mesh, robot, 0.1, -0.01);
  // The corridor and the rooms open to it, not the larger open ground beside the building.
  EXPECT_GT(grid.free_area(), 150.0);
  const Route route = tsdf_mcl::sim::plan_route(grid, scene, robot, RouteKind::test, 1, 30.0);
  EXPECT_GT(route.length(), 30.0);
  for (std::size_t i = 0; i < route.samples().size(); i += 20) {
    const Eigen::Vector3d p = route.samples()[i].world_T_base.translation();
    EXPECT_NEAR(p.z(), 0.0, 0.02);
    // Indoors: walls (not the ground plane) all around.
    int walls = 0;
    for (int k = 0; k < 16; ++k) {
      const Eigen::Vector3f d(static_cast<float>(std::cos(k * M_PI / 8)), static_cast<float>(std::sin(k * M_PI / 8)),
                              0.0f);
      walls +=
          building.cast(Eigen::Vector3f(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.5f), d, 100.0f).hit();
    }
    EXPECT_GE(walls, 13) << "route pose " << p.transpose() << " is outdoors";
  }
}

// A requested start (with its heading) and waypoints make the route: it turns on the spot from the
// requested heading, passes each waypoint in order and ends at the last.
TEST(SimRoute, StartAndWaypointsScriptTheRoute) {
  const Office& o = office();
  tsdf_mcl::sim::RouteRequest request;
  request.start = Eigen::Vector3d(3.0, 10.2, M_PI);  // corridor, facing west
  request.waypoints = {Eigen::Vector2d(12.0, 10.2), Eigen::Vector2d(11.5, 6.0), Eigen::Vector2d(20.0, 10.3)};
  const Route route = tsdf_mcl::sim::plan_route(o.grid, o.scene, o.robot, RouteKind::test, 1, 0.0, request);
  const auto& s = route.samples();
  EXPECT_LT((s.front().world_T_base.translation().head<2>() - request.start->head<2>()).norm(), 0.08);
  EXPECT_NEAR(tsdf_mcl::rpy_of(s.front().world_T_base.linear()).z(), M_PI, 1e-9);
  EXPECT_GT(s[1].time, 2.0);  // about 180 deg at 1 rad/s before it drives east
  EXPECT_LT((s.back().world_T_base.translation().head<2>() - request.waypoints.back()).norm(), 0.08);
  std::size_t next = 0;
  for (const auto& sample : s) {
    if (next < request.waypoints.size() &&
        (sample.world_T_base.translation().head<2>() - request.waypoints[next]).norm() < 0.08) {
      ++next;
    }
  }
  EXPECT_EQ(next, request.waypoints.size());
  ASSERT_EQ(route.waypoints().size(), 4u);

  request.waypoints.push_back(Eigen::Vector2d(25.0, 30.0));  // outside the building
  try {
    tsdf_mcl::sim::plan_route(o.grid, o.scene, o.robot, RouteKind::test, 1, 0.0, request);
    FAIL() << "expected an error";
  } catch (const tsdf_mcl::Error& e) {
    EXPECT_NE(std::string(e.what()).find("waypoint 4 (25.00, 30.00)"), std::string::npos) << e.what();
  }
}
