#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "cli_test_support.hpp"
#include "sim_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/sim/route.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

using tsdf_mcl::TriangleMesh;
using tsdf_mcl::sim::BuiltInScene;
using tsdf_mcl::sim::RayCaster;
using tsdf_mcl::sim::TraversabilityGrid;
using tsdf_mcl::test::TempDir;

namespace {

// The default town (120 m, scene seed 1) with its open-air traversable floor, built once.
struct TownOnGrid {
  TownOnGrid() : town(tsdf_mcl::sim::town_scene(1)), scene(town.mesh), grid(scene, town.mesh, robot, 0.1, -1e9, true) {}
  BuiltInScene town;
  RayCaster scene;
  tsdf_mcl::sim::RobotModel robot;
  TraversabilityGrid grid;
};

const TownOnGrid& town() {
  static const TownOnGrid t;
  return t;
}

// The centres of the crossings of a north-south and an east-west street.
std::vector<Eigen::Vector2f> crossings(const BuiltInScene& town) {
  std::vector<Eigen::Vector2f> out;
  for (const auto& a : town.streets) {
    for (const auto& b : town.streets) {
      const Eigen::AlignedBox2f both = a.intersection(b);
      const bool crossing =
          &a != &b && !both.isEmpty() && both.sizes().minCoeff() > 7.0f && both.sizes().maxCoeff() < 15.0f;
      if (crossing && a.sizes().y() > a.sizes().x()) out.push_back(both.center());
    }
  }
  return out;
}

bool free_at(const TraversabilityGrid& grid, const Eigen::Vector2f& p) {
  const int i = grid.index_of(p.cast<double>());
  return i >= 0 && grid.free(i);
}

}  // namespace

TEST(SimTown, TheSeedGivesTheLayoutAndTheSizeTheExtent) {
  const TriangleMesh& a = town().town.mesh;
  const BuiltInScene again = tsdf_mcl::sim::town_scene(1);
  EXPECT_EQ(a.vertices, again.mesh.vertices);
  EXPECT_EQ(a.triangles, again.mesh.triangles);
  const BuiltInScene other = tsdf_mcl::sim::town_scene(2);
  EXPECT_NE(a.triangles.size(), other.mesh.triangles.size());
  // The ground slab spans the town; nothing stands higher than the tallest building (25 m).
  for (const TriangleMesh* m : {&a, &other.mesh}) {
    EXPECT_TRUE(m->min_corner().isApprox(Eigen::Vector3f(0.0f, 0.0f, -0.3f)));
    EXPECT_NEAR(m->max_corner().x(), 120.0f, 1e-4f);
    EXPECT_NEAR(m->max_corner().y(), 120.0f, 1e-4f);
    EXPECT_LE(m->max_corner().z(), 25.0f);
    EXPECT_GT(m->max_corner().z(), 12.0f);
  }
  EXPECT_TRUE(town().town.open_air);
  // A grid of streets: each one running north crosses each one running east.
  const auto& streets = town().town.streets;
  const auto north =
      std::count_if(streets.begin(), streets.end(), [](const auto& s) { return s.sizes().y() > 100.0f; });
  const auto east = std::count_if(streets.begin(), streets.end(), [](const auto& s) { return s.sizes().x() > 100.0f; });
  EXPECT_GE(north, 3);
  EXPECT_GE(east, 3);
  EXPECT_EQ(crossings(town().town).size(), static_cast<std::size_t>(north * east));
}

// Embree traces a few tens of thousands of triangles at the office's speed: the town stays in that range.
TEST(SimTown, TriangleCountGrowsWithTheAreaAndStaysBounded) {
  const std::size_t small = town().town.mesh.triangles.size();
  const std::size_t large = tsdf_mcl::sim::town_scene(1, 300.0).mesh.triangles.size();
  EXPECT_GT(small, 3000u);
  EXPECT_LT(small, 20000u);
  EXPECT_GT(large, 4 * small);
  EXPECT_LT(large, 120000u);
}

TEST(SimTown, SizesOutsideTheRangeAndSizesOfOtherScenesAreErrors) {
  EXPECT_THROW(tsdf_mcl::sim::town_scene(1, 79.0), tsdf_mcl::Error);
  EXPECT_THROW(tsdf_mcl::sim::town_scene(1, 401.0), tsdf_mcl::Error);
  EXPECT_THROW(tsdf_mcl::sim::built_in_scene("office", 1, 100.0), tsdf_mcl::Error);
  EXPECT_EQ(tsdf_mcl::sim::built_in_scene("town", 3, 90.0).mesh.max_corner().x(), 90.0f);
}

// Open air: a ray straight up from the middle of every crossing meets nothing, and from most street points
// (all but those under a tree's crown or a lamp's arm).
TEST(SimTown, TheSkyIsOpenOverTheStreets) {
  const TownOnGrid& t = town();
  const Eigen::Vector3f up(0.0f, 0.0f, 1.0f);
  const auto cross = crossings(t.town);
  ASSERT_FALSE(cross.empty());
  for (const Eigen::Vector2f& c : cross) {
    EXPECT_FALSE(t.scene.cast(Eigen::Vector3f(c.x(), c.y(), 1.0f), up, 1000.0f).hit()) << c.transpose();
  }
  std::size_t street_points = 0, open = 0;
  for (int cell = 0; cell < static_cast<int>(t.grid.size()); cell += 97) {
    if (!t.grid.free(cell)) continue;
    const Eigen::Vector2d c = t.grid.center(cell);
    ++street_points;
    const Eigen::Vector3f origin(static_cast<float>(c.x()), static_cast<float>(c.y()), t.grid.floor(cell) + 1.0f);
    open += !t.scene.cast(origin, up, 1000.0f).hit();
  }
  ASSERT_GT(street_points, 500u);
  EXPECT_GT(static_cast<double>(open) / static_cast<double>(street_points), 0.9);
}

// The robot drives the streets (the largest region; no enclosure test) and up the plaza's ramps, never onto a
// block (its kerb is 0.15 m, beyond the robot's 0.05 m step).
TEST(SimTown, StreetsAndPlazasAreTraversableBlocksAreNot) {
  const TownOnGrid& t = town();
  for (const Eigen::Vector2f& c : crossings(t.town)) EXPECT_TRUE(free_at(t.grid, c)) << c.transpose();
  std::size_t on_streets = 0, raised = 0;
  for (const int cell : t.grid.free_cells()) {
    const Eigen::Vector2f c = t.grid.center(cell).cast<float>();
    bool street = false;
    for (const auto& s : t.town.streets) street = street || s.contains(c);
    on_streets += street;
    raised += t.grid.floor(cell) > 0.85f;  // on a plaza
  }
  const std::size_t cells = t.grid.free_cells().size();
  EXPECT_GT(on_streets, cells * 8 / 10);
  EXPECT_GT(raised, 1000u);  // at least 10 m^2 of plaza
  // The two ramps of the plaza (6 deg, 0.9 m).
  const auto ramps = tsdf_mcl::sim::find_ramps(t.grid);
  EXPECT_EQ(ramps.size(), 2u);
  for (const auto& ramp : ramps) {
    float low = 1e9f, high = -1e9f;
    for (const int i : ramp) {
      low = std::min(low, t.grid.floor(i));
      high = std::max(high, t.grid.floor(i));
      EXPECT_NEAR(t.grid.slope_deg(i), 6.0f, 0.5f);
    }
    EXPECT_GT(high - low, 0.8f);
  }
  // Streets are 8-14 m wide and lined by 0.15 m kerbs: the robot keeps 0.35 m from them, cars narrow them.
  EXPECT_GT(t.grid.free_area(), 2000.0);
  EXPECT_LT(t.grid.free_area(), 120.0 * 120.0 * 0.5);
}

// simulate in a small town: a short test route along its streets, open sky in the scans, the streets described.
TEST(SimTown, SimulateDrivesATestRouteAlongTheStreets) {
  TempDir dir;
  tsdf_mcl::sim::SimulationOptions o = tsdf_mcl::test::quick_vlp16_run("town");
  o.scene_size_m = 80.0;
  o.length_m = 15.0;
  const tsdf_mcl::sim::SimulationSummary s = tsdf_mcl::sim::simulate(o, dir.path());
  EXPECT_NEAR(s.route_length_m, 15.0, 0.1);
  const tsdf_mcl::Dataset ds = tsdf_mcl::Dataset::open(dir.path());
  ASSERT_GT(ds.size(), 20u);
  nlohmann::json j;
  std::ifstream(dir / "simulation.json") >> j;
  EXPECT_TRUE(j["scene"]["open_air"].get<bool>());
  EXPECT_NE(j["scene"]["description"].get<std::string>().find("80 x 80 m"), std::string::npos);
  const auto& streets = j["scene"]["streets"]["carriageways"];
  ASSERT_GE(streets.size(), 4u);
  // Every pose is over a carriageway or a plaza (up its ramp), the sensor 0.5 m over the floor.
  const tsdf_mcl::sim::LidarModel lidar = tsdf_mcl::sim::LidarModel::vlp16(5.0);
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const Eigen::Vector3d p = ds.pose(i).translation();
    bool street = false;
    for (const auto& b : streets) {
      street = street || (p.x() >= b[0].get<double>() && p.x() <= b[2].get<double>() && p.y() >= b[1].get<double>() &&
                          p.y() <= b[3].get<double>());
    }
    EXPECT_TRUE(street || p.z() > 0.505) << i << ": " << p.transpose();
    // Rays into the sky give no return: a share of every scan is missing.
    EXPECT_LT(ds.load_scan(i).size(), lidar.rays() * 9 / 10) << i;
  }
}

TEST(SimTown, SceneSizeAndOpenAirOptions) {
  TempDir dir;
  const std::pair<std::string, std::string> cases[] = {
      {"--scene office --scene_size 100", "--scene_size applies to --scene town only"},
      {"--scene town --scene_size 1000", "--scene_size must be in [80, 400] m"},
      {"--scene town --scene_size 60", "--scene_size must be in [80, 400] m"},
  };
  for (const auto& [options, words] : cases) {
    tsdf_mcl::test::expect_one_line_error(dir, "simulate " + options + " -o " + (dir / "out").string(), words);
  }
  // The town's own mesh, read back from a file, is a street scene only with --open_air.
  const auto run =
      tsdf_mcl::test::run_cli(dir, "simulate --scene town --scene_size 80 --length 2 -o " + (dir / "a").string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto again = tsdf_mcl::test::run_cli(dir, "simulate --scene " + (dir / "a" / "scene.ply").string() +
                                                      " --open_air --length 2 -o " + (dir / "b").string());
  ASSERT_EQ(again.exit_code, 0) << again.err;
  nlohmann::json a, b;
  std::ifstream(dir / "a" / "simulation.json") >> a;
  std::ifstream(dir / "b" / "simulation.json") >> b;
  EXPECT_EQ(a["scene"]["traversable_area_m2"], b["scene"]["traversable_area_m2"]);
  EXPECT_TRUE(b["scene"]["open_air"].get<bool>());
}
