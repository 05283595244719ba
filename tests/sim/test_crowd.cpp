#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "tsdf_mcl/sim/crowd.hpp"
#include "tsdf_mcl/sim/route.hpp"
#include "sim_test_helpers.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

using tsdf_mcl::PointCloud;
using tsdf_mcl::Pose;
using tsdf_mcl::sim::Crowd;
using tsdf_mcl::sim::Walker;

namespace {

// In the office corridor, 0.5 m above the floor, looking east along it.
const Pose kSensor = tsdf_mcl::pose_from_xyz_rpy(12.0, 10.2, 0.5, 0.0, 0.0, 0.0);

// How far a world point lies from a walker's surface (side or head) at foot point `foot`.
double off_surface(const Walker& w, const Eigen::Vector3f& foot, const Eigen::Vector3d& p) {
  const double radial = (p.head<2>() - foot.head<2>().cast<double>()).norm();
  const double top = foot.z() + w.height;
  if (p.z() > top - 1e-4) return std::abs(p.z() - top) + std::max(0.0, radial - w.radius);
  return std::abs(radial - w.radius);
}

}  // namespace

// A person in front of the sensor hides the corridor behind it: its returns lie on its cylinder and carry
// triangle -1; a person moving during the sweep is seen where it is when each column fires.
TEST(SimWalkers, ScansSeeWalkersWhereTheyAreWhenEachColumnFires) {
  const auto& office = tsdf_mcl::test::office_on_grid();
  const tsdf_mcl::sim::LidarModel lidar = tsdf_mcl::sim::LidarModel::vlp16(10.0);
  Walker standing;
  standing.start = standing.end = Eigen::Vector3f(14.0f, 10.2f, 0.0f);
  std::vector<int> triangles;
  const PointCloud cloud =
      tsdf_mcl::sim::simulate_scan(office.scene, lidar, kSensor, kSensor, {0.0, 0.0}, 1, {{standing}, &triangles});
  ASSERT_EQ(triangles.size(), cloud.size());
  std::size_t on_walker = 0;
  double worst = 0.0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (triangles[i] != -1) continue;
    ++on_walker;
    worst = std::max(worst, off_surface(standing, standing.end, kSensor * cloud.points[i].cast<double>()));
  }
  EXPECT_GT(on_walker, 300u);  // 0.5 m wide at 1.75 m: about 14 deg of the 360
  EXPECT_LT(worst, 1e-4);

  // Crossing the corridor during the sweep: the column firing last sees it near the end point. The head
  // spins clockwise from +x, so the last columns look just left of +x, where the walker ends.
  Walker crossing;
  crossing.start = Eigen::Vector3f(14.0f, 9.8f, 0.0f);
  crossing.end = Eigen::Vector3f(14.0f, 10.6f, 0.0f);
  const PointCloud moving =
      tsdf_mcl::sim::simulate_scan(office.scene, lidar, kSensor, kSensor, {0.0, 0.0}, 1, {{crossing}, &triangles});
  double worst_moving = 0.0;
  std::size_t seen = 0;
  for (std::size_t i = 0; i < moving.size(); ++i) {
    if (triangles[i] != -1) continue;
    ++seen;
    const Eigen::Vector3d p = kSensor * moving.points[i].cast<double>();
    // The column's firing fraction, from the point's azimuth (clockwise from +x).
    double azimuth = -std::atan2(moving.points[i].y(), moving.points[i].x());
    if (azimuth < 0.0) azimuth += 2.0 * M_PI;
    const float f = static_cast<float>(std::round(azimuth / (2.0 * M_PI) * lidar.columns + 1.0) / lidar.columns);
    worst_moving =
        std::max(worst_moving, off_surface(crossing, crossing.start + f * (crossing.end - crossing.start), p));
  }
  EXPECT_GT(seen, 100u);
  EXPECT_LT(worst_moving, 2e-3);
}

// People walk their routes, start clear of the robot and never come within reach of it.
TEST(SimWalkers, PeopleWalkAndGiveWayToTheRobot) {
  const auto& office = tsdf_mcl::test::office_on_grid();
  const tsdf_mcl::sim::Route robot =
      tsdf_mcl::sim::plan_route(office.grid, office.scene, office.robot, tsdf_mcl::sim::RouteKind::test, 2, 40.0)
          .truncated(0.0, 40.0);
  const Crowd crowd(office.grid, office.scene, robot, 12, 7);
  ASSERT_EQ(crowd.people().size(), 12u);
  std::vector<double> walked(12, 0.0);
  double closest = 1e9;
  std::vector<Walker> last = crowd.during(0.0, 0.0);
  for (const Walker& w : last) {
    EXPECT_GE((w.end.head<2>().cast<double>() - robot.base_pose(0.0).translation().head<2>()).norm(),
              Crowd::kStartClear);
  }
  for (double t = 0.05; t <= robot.duration(); t += 0.05) {
    const std::vector<Walker> now = crowd.during(t, t);
    const Eigen::Vector2d r = robot.base_pose(t).translation().head<2>();
    for (std::size_t k = 0; k < now.size(); ++k) {
      walked[k] += (now[k].end - last[k].end).norm();
      closest = std::min(closest, (now[k].end.head<2>().cast<double>() - r).norm());
      const int cell = office.grid.index_of(now[k].end.head<2>().cast<double>());
      ASSERT_TRUE(cell >= 0 && office.grid.passable(cell));
      EXPECT_NEAR(now[k].end.z(), office.grid.floor(cell), 0.02);
    }
    last = now;
  }
  EXPECT_GT(closest, 0.55);  // a person's radius and the robot's
  for (std::size_t k = 0; k < walked.size(); ++k) {
    const Crowd::Person& p = crowd.people()[k];
    EXPECT_GT(p.speed, 0.9 - 1e-9);
    EXPECT_LT(p.speed, 1.4);
    EXPECT_GT(walked[k], 0.5 * p.speed * robot.duration()) << "person " << k;
  }
}

// A run with walkers: they are in the scans and in walkers.txt, not in scene.ply; the same seed gives the
// same walkers.
TEST(SimWalkers, RunsRecordTheWalkersButMapNone) {
  tsdf_mcl::test::TempDir a, b;
  tsdf_mcl::sim::SimulationOptions o;
  o.rate_hz = 10.0;
  o.length_m = 12.0;
  o.scan_spacing_m = 0.3;
  o.walkers = 6;
  tsdf_mcl::sim::simulate(o, a.path());
  tsdf_mcl::sim::simulate(o, b.path());
  EXPECT_EQ(tsdf_mcl::test::read_bytes(a / "walkers.txt"), tsdf_mcl::test::read_bytes(b / "walkers.txt"));
  EXPECT_EQ(tsdf_mcl::test::read_bytes(a / "scans/000010.bin"), tsdf_mcl::test::read_bytes(b / "scans/000010.bin"));
  const tsdf_mcl::Dataset ds = tsdf_mcl::Dataset::open(a.path());
  std::ifstream lines(a / "walkers.txt");
  std::size_t scans = 0, points = 0;
  for (std::string line; std::getline(lines, line); ++scans) {
    std::istringstream in(line);
    std::size_t n = 0;
    in >> n;
    points += n;
    std::size_t values = 0;
    for (double v; in >> v;) ++values;
    EXPECT_EQ(values, 3u * 6u);
  }
  EXPECT_EQ(scans, ds.size());
  EXPECT_GT(points, 1000u);
  EXPECT_EQ(tsdf_mcl::load_mesh(a / "scene.ply").triangles.size(), tsdf_mcl::sim::office_scene(1).triangles.size());
  std::ifstream in(a / "simulation.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["walkers"]["people"].size(), 6u);
  EXPECT_EQ(j["walkers"]["radius"], 0.25f);
}
