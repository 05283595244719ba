#pragma once
// Running the particle filter over the synthetic scenes of filter_test_scene.hpp: the CPU evaluator, the filter's
// sizes for a small building, a route's scans, routes through waypoints.
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "filter_test_scene.hpp"
#include "tsdf_mcl/backends/make_evaluator.hpp"
#include "tsdf_mcl/filter/particle_filter.hpp"
#include "tsdf_mcl/filter/scan_preprocessing.hpp"

namespace tsdf_mcl::test {

// The CPU backend on a fixed number of threads (results do not depend on it; the tests' run time does).
inline std::unique_ptr<SensorEvaluator> cpu_evaluator(const TsdfMap& map, int threads = 2) {
  EvaluatorOptions o;
  o.backend = Backend::kCpu;
  o.cpu_threads = threads;
  return make_evaluator(map, o);
}

// Defaults but for the sizes (a small building needs fewer particles and hypotheses), and an update every scan.
inline FilterParameters small_building_parameters() {
  FilterParameters p;
  p.initial_particles = 20000;
  p.kld.max_particles = 20000;
  p.kld.min_particles = 300;
  p.global_search.candidates = 200000;
  p.update_min_d = 0.0;
  p.update_min_a = 0.0;
  return p;
}

// Scans of a route: dense (for the gravity estimate and the walls) and preprocessed (for the sensor update).
struct Scans {
  std::vector<std::vector<Eigen::Vector3f>> dense, points;
};
inline Scans scan_route(const std::vector<Box>& boxes, const std::vector<Pose>& route, std::uint64_t seed) {
  Rng rng(seed);
  ScanPreprocessing o;
  o.max_beams = 256;
  ScanPreprocessor pre(o);
  Scans s;
  for (std::size_t i = 0; i < route.size(); ++i) {
    s.dense.push_back(simulate_scan(boxes, route[i], rng));
    s.points.push_back(pre.process(s.dense.back(), i));
  }
  return s;
}

// Poses 0.3 m apart along the waypoints at sensor height 0.9 m above `floor_z`, yaw along the path, a little
// height and tilt wobble.
inline std::vector<Pose> route_through(const std::vector<Eigen::Vector2d>& waypoints, double floor_z = 0.0) {
  std::vector<Pose> poses;
  for (std::size_t seg = 0; seg + 1 < waypoints.size(); ++seg) {
    const Eigen::Vector2d a = waypoints[seg], b = waypoints[seg + 1];
    const double yaw = std::atan2((b - a).y(), (b - a).x());
    for (double s = 0.0; s < (b - a).norm(); s += 0.3) {
      const Eigen::Vector2d p = a + s * (b - a).normalized();
      const double t = static_cast<double>(poses.size());
      poses.push_back(pose_from_xyz_rpy(p.x(), p.y(), floor_z + 0.9 + 0.03 * std::sin(0.3 * t),
                                        0.02 * std::sin(0.5 * t), 0.02 * std::cos(0.4 * t), yaw));
    }
  }
  return poses;
}

}  // namespace tsdf_mcl::test
