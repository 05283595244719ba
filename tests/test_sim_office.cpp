#include <gtest/gtest.h>

#include <cmath>

#include "sim/random.hpp"
#include "sim/route.hpp"
#include "sim/traversability.hpp"
#include "sim_test_helpers.hpp"
#include "tsdf_mcl/simulator.hpp"

using tsdf_mcl::TriangleMesh;
using tsdf_mcl::sim::RayCaster;
using tsdf_mcl::sim::RobotModel;
using tsdf_mcl::sim::TraversabilityGrid;

namespace {

const TriangleMesh& office() {
  static const TriangleMesh mesh = tsdf_mcl::sim::office_scene(1);
  return mesh;
}

Eigen::Vector3f random_direction(tsdf_mcl::sim::Rng& rng) {
  const double z = rng.uniform(-1.0, 1.0), a = rng.uniform(0.0, 2.0 * M_PI), r = std::sqrt(1.0 - z * z);
  return Eigen::Vector3d(r * std::cos(a), r * std::sin(a), z).cast<float>();
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

// From anywhere a robot can be, no ray leaves the building, and every surface seen from free space is a
// front face (the mesh's normals point into the free space, out of the solids).
TEST(SimOffice, ClosedWithOutwardNormals) {
  const RayCaster scene(office());
  const TraversabilityGrid grid(scene, office(), RobotModel{});
  const Eigen::AlignedBox3f building(Eigen::Vector3f(-0.26f, -0.26f, -0.21f), Eigen::Vector3f(50.26f, 20.26f, 3.21f));
  tsdf_mcl::sim::Rng rng(9);
  const auto& cells = grid.free_cells();
  int rays = 0;
  for (int position = 0; position < 300; ++position) {
    const int cell = cells[rng.below(cells.size())];
    const Eigen::Vector2d c = grid.center(cell);
    const Eigen::Vector3f origin(static_cast<float>(c.x()), static_cast<float>(c.y()),
                                 grid.floor(cell) + static_cast<float>(rng.uniform(0.1, 0.95)));
    for (int k = 0; k < 200; ++k, ++rays) {
      const Eigen::Vector3f d = random_direction(rng);
      const RayCaster::Hit hit = scene.cast(origin, d, 1000.0f);
      ASSERT_TRUE(hit.hit()) << "ray escapes from " << origin.transpose() << " along " << d.transpose();
      ASSERT_TRUE(building.contains(origin + hit.distance * d)) << (origin + hit.distance * d).transpose();
      const Eigen::Vector3i& t = office().triangles[static_cast<std::size_t>(hit.triangle)];
      const Eigen::Vector3f& a = office().vertices[t[0]];
      const Eigen::Vector3f n = (office().vertices[t[1]] - a).cross(office().vertices[t[2]] - a);
      ASSERT_LT(n.dot(d), 0.0f) << "back face seen from " << origin.transpose() << " along " << d.transpose();
    }
  }
  EXPECT_EQ(rays, 60000);
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
