#include <gtest/gtest.h>

#include <cmath>

#include "tsdf_mcl/sim/random.hpp"
#include "tsdf_mcl/sim/route.hpp"
#include "tsdf_mcl/sim/traversability.hpp"
#include "sim_test_helpers.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

using tsdf_mcl::TriangleMesh;
using tsdf_mcl::sim::RayCaster;
using tsdf_mcl::sim::RobotModel;
using tsdf_mcl::sim::TraversabilityGrid;

namespace {

const TriangleMesh& office() {
  static const TriangleMesh mesh = tsdf_mcl::sim::office_scene(1);
  return mesh;
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
