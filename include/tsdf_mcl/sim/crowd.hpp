#pragma once
// People walking through a test run: unmapped obstacles that move. Each walks its own route between random
// places of the traversable floor at its own pace (0.9-1.4 m/s) and gives way to the robot: it takes no
// step that ends within kGiveWay of the robot, and while the robot is closer than that it steps aside
// (off the robot's path, where the floor lets it); then it walks back to its route and on.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "tsdf_mcl/sim/route.hpp"
#include "tsdf_mcl/sim/traversability.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

class Crowd {
 public:
  struct Person {
    double speed = 0.0;                      // m/s
    std::vector<Eigen::Vector2d> waypoints;  // its route's stops, the first where it stands at the start
  };

  static constexpr double kGiveWay = 1.2;     // m
  static constexpr double kStartClear = 3.0;  // m from the robot's start, so that no one stands in its way there

  // Plans `count` people over the robot's route's duration; seed: their random stream.
  Crowd(const TraversabilityGrid& grid, const RayCaster& scene, const Route& robot_route, std::size_t count,
        std::uint64_t seed);

  // Every person as seen by a sweep from start to end (s): foot points at both times.
  std::vector<Walker> during(double start, double end) const;
  const std::vector<Person>& people() const { return people_; }

 private:
  Eigen::Vector3f foot_at(std::size_t person, double time) const;

  std::vector<Person> people_;
  std::vector<std::vector<Eigen::Vector3f>> tracks_;  // per person, the foot point every kStep s from 0
};

}  // namespace tsdf_mcl::sim
