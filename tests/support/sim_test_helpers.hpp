#pragma once
// Helpers of the simulator tests: exact point-to-mesh distances, closed scenes, running the CLI.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>
#include <utility>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/sim/random.hpp"
#include "tsdf_mcl/sim/traversability.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/io/mesh.hpp"
#include "tsdf_mcl/sim/simulator.hpp"
#include "checkout_paths.hpp"

namespace tsdf_mcl::test {

// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
inline Eigen::Vector3d closest_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                           const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

inline double distance_to_mesh(const TriangleMesh& mesh, const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>();
    const Eigen::Vector3d b = mesh.vertices[t[1]].cast<double>();
    const Eigen::Vector3d c = mesh.vertices[t[2]].cast<double>();
    best = std::min(best, (closest_on_triangle(p, a, b, c) - p).norm());
  }
  return best;
}

// A scene with its ray caster and the default robot's traversable floor.
struct SceneOnGrid {
  explicit SceneOnGrid(TriangleMesh m) : mesh(std::move(m)), scene(mesh), grid(scene, mesh, robot) {}
  TriangleMesh mesh;
  sim::RayCaster scene;
  sim::RobotModel robot;
  sim::TraversabilityGrid grid;
};

// A quick test run in a built-in scene: the VLP-16 at 5 Hz (a sweep takes a fifth of a second of route).
inline sim::SimulationOptions quick_vlp16_run(const std::string& scene) {
  sim::SimulationOptions o;
  o.scene = scene;
  o.lidar = "vlp16";
  o.rate_hz = 5.0;
  return o;
}

// The office of scene seed 1 on its grid, built once for all tests.
inline const SceneOnGrid& office_on_grid() {
  static const SceneOnGrid office(sim::office_scene(1));
  return office;
}

// Odometry against the truth, scan to scan: the summed translation errors and the distance travelled.
struct StepErrors {
  double error = 0.0, length = 0.0;
};
inline StepErrors odometry_step_errors(const Dataset& ds) {
  StepErrors e;
  for (std::size_t i = 1; i < ds.size(); ++i) {
    const Pose truth = ds.pose(i - 1).inverse() * ds.pose(i);
    const Pose odom = ds.odometry(i - 1).inverse() * ds.odometry(i);
    e.error += (truth.translation() - odom.translation()).norm();
    e.length += truth.translation().norm();
  }
  return e;
}

inline Eigen::Vector3f random_direction(sim::Rng& rng) {
  const double z = rng.uniform(-1.0, 1.0), a = rng.uniform(0.0, 2.0 * M_PI), r = std::sqrt(1.0 - z * z);
  return Eigen::Vector3d(r * std::cos(a), r * std::sin(a), z).cast<float>();
}

// From random places a robot can be (the grid's free cells, up to `height` above the floor), no ray leaves
// the building's box, and every surface seen from free space is a front face (normals point into the free
// space, out of the solids).
inline void expect_closed_with_outward_normals(const TriangleMesh& mesh, const Eigen::AlignedBox3f& building,
                                               float height = 0.95f) {
  const sim::RayCaster scene(mesh);
  const sim::TraversabilityGrid grid(scene, mesh, sim::RobotModel{});
  sim::Rng rng(9);
  const auto& cells = grid.free_cells();
  for (int position = 0; position < 300; ++position) {
    const int cell = cells[rng.below(cells.size())];
    const Eigen::Vector2d c = grid.center(cell);
    const Eigen::Vector3f origin(static_cast<float>(c.x()), static_cast<float>(c.y()),
                                 grid.floor(cell) + static_cast<float>(rng.uniform(0.1, height)));
    for (int k = 0; k < 200; ++k) {
      const Eigen::Vector3f d = random_direction(rng);
      const sim::RayCaster::Hit hit = scene.cast(origin, d, 1000.0f);
      ASSERT_TRUE(hit.hit()) << "ray escapes from " << origin.transpose() << " along " << d.transpose();
      ASSERT_TRUE(building.contains(origin + hit.distance * d)) << (origin + hit.distance * d).transpose();
      const Eigen::Vector3i& t = mesh.triangles[static_cast<std::size_t>(hit.triangle)];
      const Eigen::Vector3f& a = mesh.vertices[t[0]];
      const Eigen::Vector3f n = (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a);
      ASSERT_LT(n.dot(d), 0.0f) << "back face seen from " << origin.transpose() << " along " << d.transpose();
    }
  }
}

struct CliRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

// Runs the tsdf-mcl program with the given arguments (a shell fragment).
inline CliRun run_cli(const std::string& arguments, const std::filesystem::path& scratch) {
  const std::filesystem::path log = scratch / "cli_output.txt";
  const std::string command = std::string(cli_program()) + " " + arguments + " > '" + log.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  CliRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.output = read_bytes(log);
  return run;
}

}  // namespace tsdf_mcl::test
