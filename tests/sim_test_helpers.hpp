#pragma once
// Helpers of the simulator tests: exact point-to-mesh distances, running the CLI.
#include <sys/wait.h>

#include <Eigen/Core>
#include <algorithm>
#include <cstdlib>
#include <limits>
#include <string>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/mesh.hpp"

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

struct CliRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

// Runs the tsdf-mcl program with the given arguments (a shell fragment).
inline CliRun run_cli(const std::string& arguments, const std::filesystem::path& scratch) {
  const std::filesystem::path log = scratch / "cli_output.txt";
  const std::string command = std::string(TSDF_MCL_CLI) + " " + arguments + " > '" + log.string() + "' 2>&1";
  const int status = std::system(command.c_str());
  CliRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.output = read_bytes(log);
  return run;
}

}  // namespace tsdf_mcl::test
