#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "tsdf_mcl/sim/route.hpp"
#include "tsdf_mcl/sim/traversability.hpp"
#include "sim_test_helpers.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

using tsdf_mcl::PointCloud;
using tsdf_mcl::Pose;
using tsdf_mcl::TriangleMesh;
using tsdf_mcl::sim::BuiltInScene;
using tsdf_mcl::sim::RayCaster;

namespace {

// The building with its mirror and landmark (`built`), and its ray caster and floor.
struct Building : tsdf_mcl::test::SceneOnGrid {
  explicit Building(BuiltInScene b) : SceneOnGrid(b.mesh), built(std::move(b)) {}
  BuiltInScene built;
};

const Building& building() {
  static const Building b(tsdf_mcl::sim::symmetric_scene(1));
  return b;
}

bool is_landmark(const tsdf_mcl::sim::Landmark& l, int triangle) {
  return triangle >= static_cast<int>(l.first_triangle) &&
         triangle < static_cast<int>(l.first_triangle + l.triangle_count);
}

std::array<long, 3> millimetres(const Eigen::Vector3d& v) {
  return {std::lround(v.x() * 1000), std::lround(v.y() * 1000), std::lround(v.z() * 1000)};
}

}  // namespace

TEST(SimSymmetric, SeedPlacesFurnitureTheBuildingStays) {
  const BuiltInScene& a = building().built;
  const BuiltInScene again = tsdf_mcl::sim::symmetric_scene(1);
  EXPECT_EQ(a.mesh.vertices, again.mesh.vertices);
  EXPECT_EQ(a.mesh.triangles, again.mesh.triangles);
  const BuiltInScene other = tsdf_mcl::sim::symmetric_scene(2);
  EXPECT_NE(a.mesh.vertices, other.mesh.vertices);
  EXPECT_TRUE(a.mirror->isApprox(*other.mirror, 0.0));
  EXPECT_TRUE(a.landmark->box.isApprox(other.landmark->box));
  // 40 x 16 m inside, outer walls 0.25 m, slabs 0.2 m, ceiling 3 m.
  EXPECT_NEAR(a.mesh.max_corner().x() - a.mesh.min_corner().x(), 40.5f, 1e-4f);
  EXPECT_NEAR(a.mesh.max_corner().y() - a.mesh.min_corner().y(), 16.5f, 1e-4f);
  EXPECT_NEAR(a.mesh.max_corner().z() - a.mesh.min_corner().z(), 3.4f, 1e-4f);
}

TEST(SimSymmetric, ClosedWithOutwardNormals) {
  tsdf_mcl::test::expect_closed_with_outward_normals(
      building().built.mesh,
      Eigen::AlignedBox3f(Eigen::Vector3f(-0.26f, -0.26f, -0.21f), Eigen::Vector3f(40.26f, 16.26f, 3.21f)));
}

// The half turn maps the building onto itself, except the landmark: every vertex has an image, and a ray and
// its image hit the same surface at the same distance unless one of them hits the landmark. The landmark is
// the documented cabinet, and its place in the other wing is empty.
TEST(SimSymmetric, HalfTurnMapsTheBuildingOntoItselfExceptTheLandmark) {
  const Building& b = building();
  const tsdf_mcl::sim::Landmark& landmark = *b.built.landmark;
  const Pose& mirror = *b.built.mirror;
  EXPECT_TRUE((mirror * Eigen::Vector3d(20.0, 8.0, 1.0)).isApprox(Eigen::Vector3d(20.0, 8.0, 1.0)));
  EXPECT_TRUE((mirror * Eigen::Vector3d(3.0, 2.0, 0.5)).isApprox(Eigen::Vector3d(37.0, 14.0, 0.5)));

  const TriangleMesh& mesh = b.built.mesh;
  std::set<std::array<long, 3>> vertices;
  for (const auto& v : mesh.vertices) vertices.insert(millimetres(v.cast<double>()));
  std::set<int> landmark_vertices;
  for (std::size_t t = landmark.first_triangle; t < landmark.first_triangle + landmark.triangle_count; ++t) {
    for (int k = 0; k < 3; ++k) landmark_vertices.insert(mesh.triangles[t][k]);
  }
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const bool imaged = vertices.count(millimetres(mirror * mesh.vertices[i].cast<double>())) > 0;
    EXPECT_EQ(imaged, landmark_vertices.count(static_cast<int>(i)) == 0) << "vertex " << i;
  }

  tsdf_mcl::sim::Rng rng(5);
  int compared = 0;
  for (int k = 0; k < 20000; ++k) {
    const int cell = b.grid.free_cells()[rng.below(b.grid.free_cells().size())];
    const Eigen::Vector2d c = b.grid.center(cell);
    const Eigen::Vector3d origin(c.x(), c.y(), rng.uniform(0.1, 2.9));
    const Eigen::Vector3d d = tsdf_mcl::test::random_direction(rng).cast<double>();
    const RayCaster::Hit hit = b.scene.cast(origin.cast<float>(), d.cast<float>(), 100.0f);
    const RayCaster::Hit image =
        b.scene.cast((mirror * origin).cast<float>(), (mirror.linear() * d).cast<float>(), 100.0f);
    ASSERT_TRUE(hit.hit() && image.hit());
    if (is_landmark(landmark, hit.triangle) || is_landmark(landmark, image.triangle)) continue;
    ++compared;
    ASSERT_NEAR(hit.distance, image.distance, 1e-4f) << origin.transpose() << " along " << d.transpose();
  }
  EXPECT_GT(compared, 19000);

  const Eigen::AlignedBox3f& box = landmark.box;
  EXPECT_TRUE(box.min().isApprox(Eigen::Vector3f(32.6f, 2.6f, 0.0f)));
  EXPECT_TRUE(box.max().isApprox(Eigen::Vector3f(33.8f, 3.2f, 1.6f)));
  const Eigen::Vector3f image = (mirror * box.center().cast<double>()).cast<float>();
  for (const Eigen::Vector3f& d : {Eigen::Vector3f(1, 0, 0), Eigen::Vector3f(-1, 0, 0), Eigen::Vector3f(0, 1, 0)}) {
    EXPECT_GT(b.scene.cast(image, d, 10.0f).distance, 1.0f);
  }
}

// Scans from a pose and from its mirror pose are the same, point for point, unless one of them sees the
// landmark; the scans that see it differ where they do.
TEST(SimSymmetric, MirrorPosesSeeTheSameScanAwayFromTheLandmark) {
  const Building& b = building();
  const tsdf_mcl::sim::LidarModel lidar = tsdf_mcl::sim::LidarModel::vlp16(20.0);
  const tsdf_mcl::sim::ScanNoise exact{0.0, 0.0};
  const Pose& mirror = *b.built.mirror;
  auto scan = [&](const Pose& pose, std::size_t& on_landmark) {
    std::vector<int> triangles;
    const PointCloud cloud = tsdf_mcl::sim::simulate_scan(b.scene, lidar, pose, pose, exact, 7, {{}, &triangles});
    on_landmark = static_cast<std::size_t>(
        std::count_if(triangles.begin(), triangles.end(), [&](int t) { return is_landmark(*b.built.landmark, t); }));
    return cloud;
  };
  tsdf_mcl::sim::Rng rng(3);
  int compared = 0;
  for (int k = 0; k < 24; ++k) {
    const int cell = b.grid.free_cells()[rng.below(b.grid.free_cells().size())];
    const Eigen::Vector2d c = b.grid.center(cell);
    const Pose pose = tsdf_mcl::pose_from_xyz_rpy(c.x(), c.y(), 0.5, rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1),
                                                  rng.uniform(-M_PI, M_PI));
    std::size_t seen = 0, seen_mirrored = 0;
    const PointCloud a = scan(pose, seen), m = scan(mirror * pose, seen_mirrored);
    if (seen > 0 || seen_mirrored > 0) continue;
    ++compared;
    ASSERT_EQ(a.size(), m.size()) << "pose " << c.transpose();
    // A ray that grazes an edge or a corner may pass on one side and hit on the other: the mirrored pose's
    // rays differ from the originals' in the last bits (the compiler's rounding decides), and at a grazing
    // angle that picks another triangle. Every other ray must agree.
    std::size_t differ = 0;
    for (std::size_t i = 0; i < a.size(); ++i) differ += (a.points[i] - m.points[i]).norm() >= 1e-3f;
    EXPECT_LE(differ, a.size() / 1000) << "pose " << c.transpose();
  }
  EXPECT_GT(compared, 15);

  // In the landmark's room, facing it: hundreds of returns on the cabinet, and the mirror pose's scan differs
  // by more than the cabinet's distance to the wall behind it on those rays.
  const Eigen::Vector2d view = b.built.landmark->viewpoint;
  const Pose facing = tsdf_mcl::pose_from_xyz_rpy(view.x(), view.y(), 0.5, 0.0, 0.0, -M_PI / 2);
  std::size_t seen = 0, seen_mirrored = 0;
  const PointCloud a = scan(facing, seen), m = scan(mirror * facing, seen_mirrored);
  EXPECT_GT(seen, 300u);
  ASSERT_EQ(a.size(), m.size());
  std::size_t differ = 0;
  for (std::size_t i = 0; i < a.size(); ++i) differ += (a.points[i] - m.points[i]).norm() > 0.5f;
  EXPECT_GE(differ, seen / 2);
}

// Test routes start far from the landmark, out of its sight, and pass it; seeds give other starts.
TEST(SimSymmetric, TestRoutesStartAwayFromTheLandmarkAndPassIt) {
  const Building& b = building();
  tsdf_mcl::sim::RouteRequest request;
  request.landmark = b.built.landmark->viewpoint;
  std::vector<Eigen::Vector2d> starts;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const tsdf_mcl::sim::Route route =
        tsdf_mcl::sim::plan_route(b.grid, b.scene, b.robot, tsdf_mcl::sim::RouteKind::test, seed, 40.0, request);
    const Eigen::Vector2d start = route.samples().front().world_T_base.translation().head<2>();
    starts.push_back(start);
    const Eigen::Vector2d cabinet = b.built.landmark->box.center().head<2>().cast<double>();
    EXPECT_GT((start - cabinet).norm(), 8.0) << "seed " << seed;
    double closest = 1e9, driven_before = 0.0;
    for (const auto& s : route.samples()) {
      const double d = (s.world_T_base.translation().head<2>() - request.landmark.value()).norm();
      if (d < closest) {
        closest = d;
        driven_before = s.distance;
      }
    }
    EXPECT_LT(closest, 0.1) << "seed " << seed;
    EXPECT_GT(driven_before, 12.0) << "seed " << seed;
    EXPECT_GT(route.length(), 40.0) << "seed " << seed;
  }
  EXPECT_GT((starts[0] - starts[1]).norm() + (starts[1] - starts[2]).norm(), 1.0);
}

// A run writes the symmetry and when the landmark comes into view; the first scans do not see it.
TEST(SimSymmetric, RunRecordsTheSymmetryAndTheLandmarkSightings) {
  tsdf_mcl::test::TempDir dir;
  tsdf_mcl::sim::SimulationOptions o = tsdf_mcl::test::quick_vlp16_run("symmetric");
  o.length_m = 25.0;
  o.scan_spacing_m = 0.3;
  const auto summary = tsdf_mcl::sim::simulate(o, dir.path());
  ASSERT_TRUE(summary.landmark_first_seen_scan.has_value());
  std::ifstream in(dir / "simulation.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  const auto& m = j["scene"]["symmetry"]["world_T_mirror"];
  EXPECT_EQ(m, nlohmann::json({{-1.0, 0.0, 0.0, 40.0}, {0.0, -1.0, 0.0, 16.0}, {0.0, 0.0, 1.0, 0.0}}));
  EXPECT_EQ(j["landmark"]["name"], "display cabinet");
  EXPECT_EQ(j["landmark"]["first_seen_scan"], *summary.landmark_first_seen_scan);
  const tsdf_mcl::Dataset ds = tsdf_mcl::Dataset::open(dir.path());
  std::vector<std::size_t> points;
  std::ifstream counts(dir / "landmark_points.txt");
  for (std::size_t n; counts >> n;) points.push_back(n);
  ASSERT_EQ(points.size(), ds.size());
  const std::size_t first = *summary.landmark_first_seen_scan;
  EXPECT_GT(first, 20u);  // 4 s or more of driving through the look-alike part
  EXPECT_GT(points[first], 0u);
  for (std::size_t i = 0; i < first; ++i) EXPECT_EQ(points[i], 0u) << "scan " << i;
  EXPECT_GT(*std::max_element(points.begin(), points.end()), 1000u);
  EXPECT_NEAR(j["landmark"]["first_seen_time_s"].get<double>(), ds.time(first), 1e-9);
}
