#pragma once
// simulation.json, the run description simulate writes beside the scans: every parameter, the scene, the route and
// the counts, to reproduce or interpret a run.
#include <Eigen/Core>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <vector>

#include "tsdf_mcl/sim/crowd.hpp"
#include "tsdf_mcl/sim/route.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

// An unmapped, people-sized box beside a test route.
struct Obstacle {
  Eigen::Vector3f min, max;
};

// When and how much of the landmark each scan sees.
struct LandmarkSightings {
  std::vector<std::size_t> points;  // per scan, returns on the landmark
  std::optional<std::size_t> first_scan;
  double first_time_s = 0.0, first_distance_m = 0.0;
};

// Everything a run used and produced, for simulation.json.
struct RunRecord {
  const SimulationOptions& options;
  const BuiltInScene& scene;  // its mesh holds the obstacles
  const LidarModel& lidar;
  const RobotModel& robot;
  const Route& route;
  const std::vector<Obstacle>& obstacles;
  const LandmarkSightings& sightings;
  const Crowd& crowd;
  std::size_t sweeps;
  const SimulationSummary& summary;
};

// Writes the description of the run `r` to `file` (atomically).
void write_description(const std::filesystem::path& file, const RunRecord& r);

}  // namespace tsdf_mcl::sim
