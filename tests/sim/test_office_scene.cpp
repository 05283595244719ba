// The built-in office (office_scene.cpp): the one-storey office with its ramps, and the two-storey office (issue
// 16's multi-storey building): two storeys of one plan joined by a staircase, and simulate's routes over storeys.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "sim_test_helpers.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/sim/random.hpp"
#include "tsdf_mcl/sim/route.hpp"
#include "tsdf_mcl/sim/simulator.hpp"
#include "tsdf_mcl/sim/traversability.hpp"

using tsdf_mcl::TriangleMesh;
using tsdf_mcl::sim::BuiltInScene;
using tsdf_mcl::sim::RayCaster;
using tsdf_mcl::sim::RobotModel;
using tsdf_mcl::sim::TraversabilityGrid;

namespace {

const TriangleMesh& office() {
  static const TriangleMesh mesh = tsdf_mcl::sim::office_scene(1);
  return mesh;
}

constexpr float kRise = 3.2f;  // the upper storey's floor

const tsdf_mcl::test::SceneOnGrid& lower_storey() {
  static const tsdf_mcl::test::SceneOnGrid b(tsdf_mcl::sim::two_storey_scene(1).mesh);
  return b;
}

const BuiltInScene& building() {
  static const BuiltInScene b = tsdf_mcl::sim::two_storey_scene(1);
  return b;
}

bool on_landmark(const tsdf_mcl::sim::Landmark& l, int triangle) {
  return triangle >= static_cast<int>(l.first_triangle) &&
         triangle < static_cast<int>(l.first_triangle + l.triangle_count);
}

}  // namespace

TEST(SimOffice, SameSeedSameMeshOtherSeedOtherFurniture) {
  const TriangleMesh again = tsdf_mcl::sim::office_scene(1);
  EXPECT_EQ(office().vertices, again.vertices);
  EXPECT_EQ(office().triangles, again.triangles);
  const TriangleMesh other = tsdf_mcl::sim::office_scene(2);
  EXPECT_NE(office().vertices, other.vertices);
  // Shell, levels, walls and pillars are the same for every seed: about 50 x 20 x 3 m.
  EXPECT_NEAR(other.min_corner().x(), office().min_corner().x(), 1e-6f);
  EXPECT_NEAR(office().max_corner().x() - office().min_corner().x(), 50.5f, 0.01f);
  EXPECT_NEAR(office().max_corner().y() - office().min_corner().y(), 20.5f, 0.01f);
  EXPECT_NEAR(office().max_corner().z() - office().min_corner().z(), 3.4f, 0.01f);
}

TEST(SimOffice, ClosedWithOutwardNormals) {
  tsdf_mcl::test::expect_closed_with_outward_normals(
      office(), Eigen::AlignedBox3f(Eigen::Vector3f(-0.26f, -0.26f, -0.21f), Eigen::Vector3f(50.26f, 20.26f, 3.21f)));
}

TEST(SimOffice, FloorHasTwoRampsAndRoomForARobot) {
  const RayCaster scene(office());
  const TraversabilityGrid grid(scene, office(), RobotModel{});
  // Rooms, corridor, hall, stage and east wing, less furniture and clearance.
  EXPECT_GT(grid.free_area(), 450.0);
  EXPECT_LT(grid.free_area(), 750.0);
  const auto ramps = tsdf_mcl::sim::find_ramps(grid);
  ASSERT_EQ(ramps.size(), 2u);
  std::vector<double> slopes;
  for (const auto& ramp : ramps) slopes.push_back(grid.slope_deg(ramp[ramp.size() / 2]));
  std::sort(slopes.begin(), slopes.end());
  EXPECT_NEAR(slopes[0], 7.13, 0.1);  // corridor ramp: 0.5 m over 4 m
  EXPECT_NEAR(slopes[1], 8.53, 0.1);  // stage ramp: 0.45 m over 3 m
  // Both floor levels are reachable: the hall (0 m), the stage (0.45 m) and the east wing (0.5 m).
  bool low = false, stage = false, wing = false;
  for (int i : grid.free_cells()) {
    low = low || std::abs(grid.floor(i)) < 1e-3f;
    stage = stage || std::abs(grid.floor(i) - 0.45f) < 1e-3f;
    wing = wing || std::abs(grid.floor(i) - 0.5f) < 1e-3f;
  }
  EXPECT_TRUE(low && stage && wing);
}

TEST(SimTwoStorey, ClosedWithOutwardNormals) {
  EXPECT_EQ(building().storey_floors, (std::vector<float>{0.0f, kRise}));
  tsdf_mcl::test::expect_closed_with_outward_normals(
      building().mesh,
      Eigen::AlignedBox3f(Eigen::Vector3f(-0.26f, -0.26f, -0.21f), Eigen::Vector3f(50.26f, 20.26f, 6.41f)));
}

// One plan: from any place on the lower storey and the same place one storey up, a ray meets the same surface at
// the same distance, unless it meets the staircase or its railing (the landmark) or passes through the opening in
// the slab between the storeys.
TEST(SimTwoStorey, StoreysRepeatOnePlanExceptTheStaircase) {
  const tsdf_mcl::test::SceneOnGrid& lower = lower_storey();
  const tsdf_mcl::sim::Landmark& landmark = *building().landmark;
  EXPECT_EQ(landmark.name, "staircase");
  tsdf_mcl::sim::Rng rng(4);
  const auto& cells = lower.grid.free_cells();
  std::size_t compared = 0, landmark_hits = 0;
  for (int position = 0; position < 200; ++position) {
    const int cell = cells[rng.below(cells.size())];
    const Eigen::Vector2d c = lower.grid.center(cell);
    const Eigen::Vector3f below(static_cast<float>(c.x()), static_cast<float>(c.y()),
                                lower.grid.floor(cell) + static_cast<float>(rng.uniform(0.2, 2.0)));
    const Eigen::Vector3f above = below + Eigen::Vector3f(0.0f, 0.0f, kRise);
    for (int k = 0; k < 100; ++k) {
      const Eigen::Vector3f d = tsdf_mcl::test::random_direction(rng);
      const RayCaster::Hit a = lower.scene.cast(below, d, 1000.0f);
      const RayCaster::Hit b = lower.scene.cast(above, d, 1000.0f);
      ASSERT_TRUE(a.hit() && b.hit());
      if (on_landmark(landmark, a.triangle) || on_landmark(landmark, b.triangle)) {
        ++landmark_hits;
        continue;
      }
      if ((below + a.distance * d).z() > kRise - 0.2f || (above + b.distance * d).z() < kRise) continue;  // opening
      ++compared;
      ASSERT_NEAR(a.distance, b.distance, 1e-3f) << below.transpose() << " along " << d.transpose();
    }
  }
  EXPECT_GT(compared, 19000u);
  EXPECT_GT(landmark_hits, 0u);
}

TEST(SimTwoStorey, JoinedRoutesKeepTimeAndDistanceAndMarkThePause) {
  const tsdf_mcl::test::SceneOnGrid& o = tsdf_mcl::test::office_on_grid();
  using tsdf_mcl::sim::Route;
  const Route a = tsdf_mcl::sim::plan_route(o.grid, o.scene, o.robot, tsdf_mcl::sim::RouteKind::test, 1, 10.0);
  const Route b = tsdf_mcl::sim::plan_route(o.grid, o.scene, o.robot, tsdf_mcl::sim::RouteKind::test, 2, 10.0);
  const Route joined = Route::joined({a, b}, 4.0);
  ASSERT_EQ(joined.samples().size(), a.samples().size() + b.samples().size());
  EXPECT_NEAR(joined.duration(), a.duration() + 4.0 + b.duration(), 1e-9);
  EXPECT_NEAR(joined.length(), a.length() + b.length(), 1e-9);
  ASSERT_EQ(joined.pauses().size(), 1u);
  EXPECT_NEAR(joined.pauses()[0].first, a.duration(), 1e-9);
  EXPECT_TRUE(joined.overlaps_pause(a.duration() + 1.0, a.duration() + 1.1));
  EXPECT_FALSE(joined.overlaps_pause(0.0, a.duration() - 0.1));
  EXPECT_TRUE(joined.base_pose(a.duration() + 4.0).isApprox(b.samples().front().world_T_base));
  EXPECT_TRUE(joined.truncated(a.duration() - 1.0, 0.0).pauses().empty());
  EXPECT_EQ(joined.truncated(a.duration() + 5.0, 0.0).pauses().size(), 1u);
  EXPECT_THROW(Route::joined({}, 1.0), tsdf_mcl::Error);
  EXPECT_THROW(Route::joined({a, b}, 0.0), tsdf_mcl::Error);
}

// A mapping run covers both storeys, carried from one to the other with no scan then. A LiDAR of two beams and
// sparse scans keep it quick: the route is what is checked.
TEST(SimTwoStorey, MappingRunCoversBothStoreysAndScansNothingWhileCarried) {
  tsdf_mcl::test::TempDir dir;
  {
    std::ofstream beams(dir / "two_beams.txt");
    beams << "columns 64\nmin_range 0.3\nmax_range 30\nrate 5\n-10\n10\n";
  }
  tsdf_mcl::sim::SimulationOptions o;
  o.scene = "two-storey";
  o.lidar = (dir / "two_beams.txt").string();
  o.route = tsdf_mcl::sim::RouteKind::mapping;
  o.scan_spacing_m = 5.0;
  tsdf_mcl::sim::simulate(o, dir / "run");
  const tsdf_mcl::Dataset ds = tsdf_mcl::Dataset::open(dir / "run");
  std::ifstream in(dir / "run" / "simulation.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["route"]["carried"]["intervals_s"].size(), 1u);
  const double from = j["route"]["carried"]["intervals_s"][0][0].get<double>();
  const double to = j["route"]["carried"]["intervals_s"][0][1].get<double>();
  EXPECT_NEAR(to - from, 5.0, 1e-9);
  std::size_t lower = 0, upper = 0;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const double z = ds.pose(i).translation().z();
    lower += z < 1.2;
    upper += z > kRise + 0.4 && z < kRise + 1.2;
    EXPECT_TRUE(z < 1.2 || (z > kRise + 0.4 && z < kRise + 1.2)) << "scan " << i << " at z " << z;
    // A sweep's scan spans one period before its time.
    EXPECT_FALSE(ds.time(i) > from - 0.5 && ds.time(i) - 0.2 < to + 0.5) << "scan " << i << " while carried";
    if (ds.time(i) < from) {
      EXPECT_LT(z, 1.2) << "scan " << i << ": the lower storey first";
    } else {
      EXPECT_GT(z, kRise) << "scan " << i << ": then the upper one";
    }
  }
  EXPECT_GT(lower, 50u);
  EXPECT_GT(upper, 50u);
  EXPECT_EQ(j["scene"]["storey_floors"], nlohmann::json({0.0, kRise}));
}

// A test route runs on the storey asked for, passes the staircase and sees it.
TEST(SimTwoStorey, TestRouteRunsOnTheStoreyAskedFor) {
  tsdf_mcl::test::TempDir dir;
  tsdf_mcl::sim::SimulationOptions o = tsdf_mcl::test::quick_vlp16_run("two-storey");
  o.scan_spacing_m = 1.0;
  o.storey = 1;
  const auto summary = tsdf_mcl::sim::simulate(o, dir.path());
  ASSERT_TRUE(summary.landmark_first_seen_scan.has_value());
  const tsdf_mcl::Dataset ds = tsdf_mcl::Dataset::open(dir.path());
  for (std::size_t i = 0; i < ds.size(); ++i) EXPECT_NEAR(ds.pose(i).translation().z(), kRise + 0.5, 0.55) << i;
  std::ifstream in(dir / "simulation.json");
  EXPECT_EQ(nlohmann::json::parse(in)["route"]["storey"], 1);

  o.storey = 2;
  EXPECT_THROW(
      {
        try {
          tsdf_mcl::sim::simulate(o, dir / "other");
        } catch (const tsdf_mcl::Error& e) {
          EXPECT_NE(std::string(e.what()).find("2 storeys (0 to 1)"), std::string::npos) << e.what();
          throw;
        }
      },
      tsdf_mcl::Error);
}
