#include "tsdf_mcl/sim/crowd.hpp"

#include <algorithm>
#include <cmath>

#include "tsdf_mcl/sim/random.hpp"

namespace tsdf_mcl::sim {

namespace {

using Eigen::Vector2d;

constexpr double kStep = 0.05;  // s between track points

Vector2d xy(const Pose& pose) { return pose.translation().head<2>(); }

// Where a person fits: passable floor 0.3 m from anything (a person is slimmer than the robot's free region
// asks for, so it can step aside in a corridor the robot drives down the middle of).
bool fits_at(const TraversabilityGrid& grid, const Vector2d& p) {
  const int i = grid.index_of(p);
  return i >= 0 && grid.passable(i) && grid.clearance(i) >= 0.3f;
}

// A start clear of the robot's, then stops 5-25 m apart until the walk is long enough.
std::vector<Vector2d> walk_stops(const TraversabilityGrid& grid, const Vector2d& robot_start, double length, Rng& rng) {
  const auto& cells = grid.free_cells();
  auto random_cell = [&](auto accept) {
    for (int attempt = 0; attempt < 10000; ++attempt) {
      const Vector2d c = grid.center(cells[rng.below(cells.size())]);
      if (accept(c)) return c;
    }
    return grid.center(cells[rng.below(cells.size())]);  // a floor too small to be choosy
  };
  std::vector<Vector2d> stops{
      random_cell([&](const Vector2d& c) { return (c - robot_start).norm() >= Crowd::kStartClear; })};
  for (double planned = 0.0; planned < length;) {
    const Vector2d last = stops.back();
    stops.push_back(random_cell([&](const Vector2d& c) {
      const double d = (c - last).norm();
      return d >= 5.0 && d <= 25.0;
    }));
    planned += (stops.back() - last).norm();
  }
  return stops;
}

// A step (stride long) of a person at p making way for the robot: sideways off the robot's path, else
// straight away from the robot, else across its path; never closer to the robot, never off the floor.
Vector2d make_way(const TraversabilityGrid& grid, const Vector2d& p, const Pose& robot, double stride) {
  const Vector2d from_robot = p - xy(robot);
  const Vector2d forward = robot.linear().col(0).head<2>().normalized();
  Vector2d side(-forward.y(), forward.x());
  if (side.dot(from_robot) < 0.0) side = -side;
  const Vector2d away = from_robot.norm() > 1e-9 ? from_robot.normalized() : side;
  for (const Vector2d& direction : {side, away, Vector2d(-side)}) {
    const Vector2d q = p + stride * direction;
    if (fits_at(grid, q) && (q - xy(robot)).norm() > from_robot.norm()) return q;
  }
  return p;
}

// The person's foot point every kStep s: along its own route, back to it after making way, waiting while a
// step would bring it within kGiveWay of the robot.
std::vector<Eigen::Vector3f> track(const TraversabilityGrid& grid, const Route& walk, const Route& robot_route,
                                   double speed) {
  const auto steps = static_cast<std::size_t>(std::ceil(robot_route.duration() / kStep)) + 1;
  const double stride = speed * kStep;
  std::vector<Eigen::Vector3f> points;
  points.reserve(steps);
  double own_time = 0.0;  // how far along its route it is
  Vector2d p = xy(walk.base_pose(0.0));
  for (std::size_t i = 0; i < steps; ++i) {
    const Pose robot = robot_route.base_pose(static_cast<double>(i) * kStep);
    if ((p - xy(robot)).norm() < Crowd::kGiveWay) {
      p = make_way(grid, p, robot, stride);
    } else {
      const Vector2d on_route = xy(walk.base_pose(own_time));
      const bool astray = (p - on_route).norm() > stride;
      const Vector2d next =
          astray ? Vector2d(p + stride * (on_route - p).normalized()) : xy(walk.base_pose(own_time + kStep));
      if ((next - xy(robot)).norm() >= Crowd::kGiveWay) {
        p = next;
        if (!astray) own_time += kStep;
      }
    }
    points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), grid.floor(grid.index_of(p)));
  }
  return points;
}

}  // namespace

Crowd::Crowd(const TraversabilityGrid& grid, const RayCaster& scene, const Route& robot_route, std::size_t count,
             std::uint64_t seed) {
  const Vector2d robot_start = xy(robot_route.base_pose(0.0));
  for (std::size_t k = 0; k < count; ++k) {
    Rng rng(mix_key(seed, k));
    Person person;
    person.speed = rng.uniform(0.9, 1.4);
    RobotModel pedestrian;
    pedestrian.speed = person.speed;
    pedestrian.max_turn_rate = 2.0;
    pedestrian.max_acceleration = 1.0;
    RouteRequest request;
    request.waypoints = walk_stops(grid, robot_start, person.speed * robot_route.duration() + 5.0, rng);
    person.waypoints = request.waypoints;
    const Route walk = plan_route(grid, scene, pedestrian, RouteKind::test, mix_key(seed, k), 0.0, request);
    tracks_.push_back(track(grid, walk, robot_route, person.speed));
    people_.push_back(std::move(person));
  }
}

Eigen::Vector3f Crowd::foot_at(std::size_t person, double time) const {
  const std::vector<Eigen::Vector3f>& t = tracks_[person];
  const double at = std::clamp(time / kStep, 0.0, static_cast<double>(t.size() - 1));
  const auto i = std::min(static_cast<std::size_t>(at), t.size() - 2);
  const auto f = static_cast<float>(at - static_cast<double>(i));
  return t[i] + f * (t[i + 1] - t[i]);
}

std::vector<Walker> Crowd::during(double start, double end) const {
  std::vector<Walker> walkers(people_.size());
  for (std::size_t k = 0; k < people_.size(); ++k) {
    walkers[k].start = foot_at(k, start);
    walkers[k].end = foot_at(k, end);
  }
  return walkers;
}

}  // namespace tsdf_mcl::sim
