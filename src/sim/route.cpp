#include "tsdf_mcl/sim/route.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <queue>
#include <string>
#include <tuple>

#include "interpolate.hpp"
#include "tsdf_mcl/sim/random.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::sim {

namespace {

using Eigen::Vector2d;

constexpr int kSteps[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr double kSampleSpacing = 0.05;                // m between route samples
constexpr double kRampApproach = 1.2;                  // m driven on the level floor before and after a ramp
constexpr double kLandmarkApproach[2] = {15.0, 45.0};  // m (geodesic) from the start to a landmark
constexpr double kSnapDistance = 1.0;                  // m: requested points this close to the free region snap onto it

float step_length(int s, double cell) { return static_cast<float>((s < 4 ? 1.0 : M_SQRT2) * cell); }

// Shortest distances (m) over free cells from `source` (8-connected); infinity elsewhere. Free cells never
// touch the grid's border, so neighbours of a free cell are inside the grid.
std::vector<float> geodesic(const TraversabilityGrid& grid, int source) {
  std::vector<float> dist(grid.size(), kInf);
  using Item = std::pair<float, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  dist[source] = 0.0f;
  open.push({0.0f, source});
  while (!open.empty()) {
    const auto [d, i] = open.top();
    open.pop();
    if (d > dist[i]) continue;
    const Eigen::Vector2i c = grid.coords(i);
    for (int s = 0; s < 8; ++s) {
      const int j = grid.index(c.x() + kSteps[s][0], c.y() + kSteps[s][1]);
      const float nd = d + step_length(s, grid.cell());
      if (grid.free(j) && nd < dist[j]) {
        dist[j] = nd;
        open.push({nd, j});
      }
    }
  }
  return dist;
}

// A* over free cells; moving through a cell costs more the closer it is to an obstacle, so paths keep to
// the middle of corridors and doors as a navigation stack with an inflated costmap does.
std::vector<int> astar(const TraversabilityGrid& grid, const RobotModel& robot, int from, int to) {
  const Vector2d goal = grid.center(to);
  auto heuristic = [&](int i) {
    const Vector2d d = (grid.center(i) - goal).cwiseAbs();
    return static_cast<float>(std::max(d.x(), d.y()) + (M_SQRT2 - 1.0) * std::min(d.x(), d.y()));
  };
  auto penalty = [&](int i) {
    const double excess = grid.clearance(i) - robot.radius;
    return static_cast<float>(1.0 + 3.0 * std::max(0.0, 1.0 - excess / 0.8));
  };
  std::vector<float> cost(grid.size(), kInf);
  std::vector<int> parent(grid.size(), -1);
  using Item = std::pair<float, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  cost[from] = 0.0f;
  open.push({heuristic(from), from});
  while (!open.empty()) {
    const auto [f, i] = open.top();
    open.pop();
    if (i == to) break;
    if (f - heuristic(i) > cost[i] + 1e-4f) continue;
    const Eigen::Vector2i c = grid.coords(i);
    for (int s = 0; s < 8; ++s) {
      const int j = grid.index(c.x() + kSteps[s][0], c.y() + kSteps[s][1]);
      if (!grid.free(j)) continue;
      const float nc = cost[i] + step_length(s, grid.cell()) * penalty(j);
      if (nc < cost[j]) {
        cost[j] = nc;
        parent[j] = i;
        open.push({nc + heuristic(j), j});
      }
    }
  }
  if (cost[to] == kInf) throw Error("route planning: no path between two waypoints of the free region");
  std::vector<int> path;
  for (int i = to; i != -1; i = parent[i]) path.push_back(i);
  std::reverse(path.begin(), path.end());
  return path;
}

bool free_at(const TraversabilityGrid& grid, const Vector2d& p) {
  const int i = grid.index_of(p);
  return i >= 0 && grid.free(i);
}

// Gradient smoothing of the grid path (data term alpha, smoothness term beta); waypoints stay put and no
// point leaves the free region.
void smooth(const TraversabilityGrid& grid, std::vector<Vector2d>& path, const std::vector<bool>& fixed) {
  const std::vector<Vector2d> original = path;
  const double alpha = 0.1, beta = 0.3;
  for (int iteration = 0; iteration < 200; ++iteration) {
    for (std::size_t i = 1; i + 1 < path.size(); ++i) {
      if (fixed[i]) continue;
      const Vector2d moved =
          path[i] + alpha * (original[i] - path[i]) + beta * (path[i - 1] + path[i + 1] - 2.0 * path[i]);
      if (free_at(grid, moved)) path[i] = moved;
    }
  }
}

std::vector<Vector2d> resample(const std::vector<Vector2d>& path, double spacing) {
  std::vector<Vector2d> out{path.front()};
  double to_next = spacing;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const Vector2d a = path[i], b = path[i + 1];
    const double length = (b - a).norm();
    double at = 0.0;
    while (length - at >= to_next) {
      at += to_next;
      out.push_back(a + (b - a) * (at / length));
      to_next = spacing;
    }
    to_next -= length - at;
  }
  if ((out.back() - path.back()).norm() > 1e-6) out.push_back(path.back());
  return out;
}

// Floor height under p, from a short ray down from just above the cell's floor.
double contact_height(const TraversabilityGrid& grid, const RayCaster& scene, const Vector2d& p, double fallback) {
  const int i = grid.index_of(p);
  const double start = (i >= 0 && !std::isnan(grid.floor(i)) ? grid.floor(i) : fallback) + 0.3;
  const RayCaster::Hit hit =
      scene.cast(Eigen::Vector3f(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(start)),
                 Eigen::Vector3f(0.0f, 0.0f, -1.0f), 0.6f);
  return hit.hit() ? start - hit.distance : start - 0.3;
}

Pose base_pose_on_floor(const TraversabilityGrid& grid, const RayCaster& scene, const RobotModel& robot,
                        const Vector2d& p, double yaw) {
  const Vector2d forward(std::cos(yaw), std::sin(yaw));
  const Vector2d left(-forward.y(), forward.x());
  const int i = grid.index_of(p);
  const double fallback = grid.floor(i);
  const double front = contact_height(grid, scene, p + 0.5 * robot.wheelbase * forward, fallback);
  const double back = contact_height(grid, scene, p - 0.5 * robot.wheelbase * forward, fallback);
  const double l = contact_height(grid, scene, p + 0.5 * robot.track * left, fallback);
  const double r = contact_height(grid, scene, p - 0.5 * robot.track * left, fallback);
  const Eigen::Vector3d x_axis =
      Eigen::Vector3d(robot.wheelbase * forward.x(), robot.wheelbase * forward.y(), front - back).normalized();
  const Eigen::Vector3d y_guess(robot.track * left.x(), robot.track * left.y(), l - r);
  const Eigen::Vector3d z_axis = x_axis.cross(y_guess).normalized();
  Pose pose = Pose::Identity();
  pose.linear().col(0) = x_axis;
  pose.linear().col(1) = z_axis.cross(x_axis);
  pose.linear().col(2) = z_axis;
  pose.translation() = Eigen::Vector3d(p.x(), p.y(), 0.25 * (front + back + l + r));
  return pose;
}

// Drives the path: curvature- and acceleration-limited speed, turning on the spot where the path folds back.
// With an initial yaw the path's first two points coincide: the robot first turns from that yaw on the spot.
std::vector<Route::Sample> drive(const TraversabilityGrid& grid, const RayCaster& scene, const RobotModel& robot,
                                 const std::vector<Vector2d>& points, std::optional<double> initial_yaw) {
  const std::size_t n = points.size();
  std::vector<double> yaw(n);
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const Vector2d d = points[i + 1] - points[i];
    yaw[i] = i == 0 && initial_yaw ? *initial_yaw : std::atan2(d.y(), d.x());
    if (i > 0) yaw[i] = yaw[i - 1] + std::remainder(yaw[i] - yaw[i - 1], 2.0 * M_PI);
  }
  yaw[n - 1] = yaw[n - 2];

  const double ds = kSampleSpacing;
  std::vector<double> speed(n);
  const std::size_t window = 5;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i >= window ? i - window : 0, b = std::min(n - 1, i + window);
    const double turn = std::abs(yaw[b] - yaw[a]);
    const double curve_limit = turn > 1e-9 ? robot.max_turn_rate * ds * static_cast<double>(b - a) / turn : robot.speed;
    speed[i] = std::min(robot.speed, curve_limit);
  }
  speed.front() = speed.back() = 0.0;
  for (std::size_t i = 1; i < n; ++i) {
    speed[i] = std::min(speed[i], std::sqrt(speed[i - 1] * speed[i - 1] + 2.0 * robot.max_acceleration * ds));
  }
  for (std::size_t i = n - 1; i-- > 0;) {
    speed[i] = std::min(speed[i], std::sqrt(speed[i + 1] * speed[i + 1] + 2.0 * robot.max_acceleration * ds));
  }

  std::vector<Route::Sample> samples(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0) {
      const double step = (points[i] - points[i - 1]).norm();
      const double move_time = step > 0.0 ? 2.0 * step / std::max(speed[i - 1] + speed[i], 1e-3) : 0.0;
      const double turn_time = std::abs(yaw[i] - yaw[i - 1]) / robot.max_turn_rate;
      samples[i].time = samples[i - 1].time + std::max(move_time, turn_time);
      samples[i].distance = samples[i - 1].distance + step;
    }
    samples[i].world_T_base = base_pose_on_floor(grid, scene, robot, points[i], yaw[i]);
  }
  return samples;
}

int nearest_free(const TraversabilityGrid& grid, const Vector2d& p) {
  int best = grid.free_cells().front();
  double best_d = std::numeric_limits<double>::infinity();
  for (int i : grid.free_cells()) {
    const double d = (grid.center(i) - p).squaredNorm();
    if (d < best_d) {
      best_d = d;
      best = i;
    }
  }
  return best;
}

// The free cell nearest to a requested point; `what` names the point in the error.
int snap_to_free(const TraversabilityGrid& grid, const Vector2d& p, const std::string& what) {
  const int i = nearest_free(grid, p);
  const double d = (grid.center(i) - p).norm();
  if (d > kSnapDistance) {
    char msg[200];
    std::snprintf(msg, sizeof(msg), "%s (%.2f, %.2f) lies %.1f m from the floor where the robot fits (at most %.1f m)",
                  what.c_str(), p.x(), p.y(), d, kSnapDistance);
    throw Error(msg);
  }
  return i;
}

// Farthest-point sampling of the free region by geodesic distance, then a short visiting order (nearest
// neighbour, improved by 2-opt) starting at a seed-chosen cell.
std::vector<int> mapping_waypoints(const TraversabilityGrid& grid, double coverage_radius, Rng& rng) {
  const auto& cells = grid.free_cells();
  std::vector<int> points{cells[rng.below(cells.size())]};
  std::vector<float> nearest = geodesic(grid, points[0]);
  std::vector<std::vector<float>> d{{0.0f}};
  while (true) {
    int far = -1;
    float far_d = static_cast<float>(coverage_radius);
    for (int i : cells) {
      if (nearest[i] > far_d) {
        far_d = nearest[i];
        far = i;
      }
    }
    if (far < 0) break;
    const std::vector<float> from_far = geodesic(grid, far);
    for (std::size_t k = 0; k < points.size(); ++k) d[k].push_back(from_far[points[k]]);
    d.emplace_back();
    for (int p : points) d.back().push_back(from_far[p]);
    d.back().push_back(0.0f);
    points.push_back(far);
    for (int i : cells) nearest[i] = std::min(nearest[i], from_far[i]);
  }

  const std::size_t n = points.size();
  std::vector<std::size_t> order{0};
  std::vector<bool> visited(n, false);
  visited[0] = true;
  for (std::size_t step = 1; step < n; ++step) {
    std::size_t next = 0;
    float best = kInf;
    for (std::size_t k = 0; k < n; ++k) {
      if (!visited[k] && d[order.back()][k] < best) {
        best = d[order.back()][k];
        next = k;
      }
    }
    visited[next] = true;
    order.push_back(next);
  }
  for (bool improved = true; improved;) {
    improved = false;
    for (std::size_t i = 1; i + 1 < n; ++i) {
      for (std::size_t j = i + 1; j < n; ++j) {
        const float before = d[order[i - 1]][order[i]] + (j + 1 < n ? d[order[j]][order[j + 1]] : 0.0f);
        const float after = d[order[i - 1]][order[j]] + (j + 1 < n ? d[order[i]][order[j + 1]] : 0.0f);
        if (after < before - 1e-3f) {
          std::reverse(order.begin() + static_cast<std::ptrdiff_t>(i),
                       order.begin() + static_cast<std::ptrdiff_t>(j) + 1);
          improved = true;
        }
      }
    }
  }
  std::vector<int> tour;
  for (std::size_t k : order) tour.push_back(points[k]);
  return tour;
}

// A random free cell whose geodesic distance from the last waypoint lies in [lo, hi] (or the farthest one).
int random_cell_at(const TraversabilityGrid& grid, const std::vector<float>& dist, double lo, double hi, Rng& rng) {
  std::vector<int> candidates;
  int farthest = grid.free_cells().front();
  for (int i : grid.free_cells()) {
    if (dist[i] >= lo && dist[i] <= hi) candidates.push_back(i);
    if (dist[i] > dist[farthest]) farthest = i;
  }
  return candidates.empty() ? farthest : candidates[rng.below(candidates.size())];
}

// start: a requested first cell (else the seed picks one); landmark: a cell the route must pass; via_ramp: start
// before a ramp where there is one.
std::vector<int> test_waypoints(const TraversabilityGrid& grid, Rng& rng, double min_length, std::optional<int> start,
                                std::optional<int> landmark, bool via_ramp) {
  std::vector<int> points;
  double planned = 0.0;
  const auto ramps = find_ramps(grid);
  if (landmark) {
    const std::vector<float> from_landmark = geodesic(grid, *landmark);
    const int first =
        start ? *start : random_cell_at(grid, from_landmark, kLandmarkApproach[0], kLandmarkApproach[1], rng);
    points = {first, *landmark};
    planned = from_landmark[first];
  } else if (ramps.empty() || !via_ramp) {
    points.push_back(start ? *start : grid.free_cells()[rng.below(grid.free_cells().size())]);
  } else {
    const auto& ramp = ramps[rng.below(ramps.size())];
    float low = kInf, high = -kInf;
    for (int i : ramp) {
      low = std::min(low, grid.floor(i));
      high = std::max(high, grid.floor(i));
    }
    // Centres of the ramp's lowest and highest fifths give its direction; the route joins it on the level
    // floor before and leaves it on the level floor after.
    Vector2d bottom = Vector2d::Zero(), top = Vector2d::Zero();
    int nb = 0, nt = 0;
    for (int i : ramp) {
      if (grid.floor(i) <= low + 0.2f * (high - low)) {
        bottom += grid.center(i);
        ++nb;
      }
      if (grid.floor(i) >= high - 0.2f * (high - low)) {
        top += grid.center(i);
        ++nt;
      }
    }
    bottom /= nb;
    top /= nt;
    const Vector2d up = (top - bottom).normalized();
    int a = nearest_free(grid, bottom - kRampApproach * up);
    int b = nearest_free(grid, top + kRampApproach * up);
    if (rng.chance(0.5)) std::swap(a, b);
    const std::vector<float> from_a = geodesic(grid, a);
    const double reach = std::max(4.0, std::min(20.0, 0.3 * min_length));
    const int first = start ? *start : random_cell_at(grid, from_a, 2.0, reach, rng);
    points = {first, a, b};
    planned = from_a[first] + from_a[b];
  }
  // Geodesic lengths overestimate the smoothed path a little: plan with a margin.
  while (planned < 1.1 * min_length + 5.0) {
    const std::vector<float> dist = geodesic(grid, points.back());
    const int next = random_cell_at(grid, dist, 5.0, 30.0, rng);
    if (dist[next] < 1.0f) break;  // a free region too small to go anywhere
    planned += dist[next];
    points.push_back(next);
  }
  return points;
}

}  // namespace

std::vector<std::vector<int>> find_ramps(const TraversabilityGrid& grid, double min_slope_deg) {
  std::vector<int> label(grid.size(), -1);
  std::vector<std::vector<int>> ramps;
  auto sloped = [&](int i) { return grid.free(i) && grid.slope_deg(i) >= min_slope_deg; };
  for (int seed : grid.free_cells()) {
    if (label[seed] >= 0 || !sloped(seed)) continue;
    std::vector<int> members{seed};
    label[seed] = seed;
    for (std::size_t head = 0; head < members.size(); ++head) {
      const Eigen::Vector2i c = grid.coords(members[head]);
      for (const auto& s : kSteps) {
        const int j = grid.index(c.x() + s[0], c.y() + s[1]);
        if (label[j] < 0 && sloped(j)) {
          label[j] = seed;
          members.push_back(j);
        }
      }
    }
    float low = kInf, high = -kInf;
    for (int i : members) {
      low = std::min(low, grid.floor(i));
      high = std::max(high, grid.floor(i));
    }
    if (static_cast<double>(members.size()) * grid.cell() * grid.cell() >= 0.2 && high - low >= 0.1f) {
      ramps.push_back(std::move(members));
    }
  }
  return ramps;
}

Route::Route(std::vector<Sample> samples, std::vector<Eigen::Vector2d> waypoints)
    : samples_(std::move(samples)), waypoints_(std::move(waypoints)) {
  if (samples_.size() < 2) throw Error("route has fewer than two poses");
}

// The samples around `time` and the fraction of the way from the first to the second.
std::tuple<const Route::Sample&, const Route::Sample&, double> Route::bracket(double time) const {
  if (time <= samples_.front().time) return {samples_.front(), samples_.front(), 0.0};
  if (time >= samples_.back().time) return {samples_.back(), samples_.back(), 0.0};
  const auto it =
      std::upper_bound(samples_.begin(), samples_.end(), time, [](double t, const Sample& s) { return t < s.time; });
  const Sample& b = *it;
  const Sample& a = *(it - 1);
  return {a, b, (time - a.time) / (b.time - a.time)};
}

Pose Route::base_pose(double time) const {
  const auto [a, b, f] = bracket(time);
  return &a == &b ? a.world_T_base : interpolate(a.world_T_base, b.world_T_base, f);
}

double Route::distance_at(double time) const {
  const auto [a, b, f] = bracket(time);
  return (1.0 - f) * a.distance + f * b.distance;
}

Route Route::truncated(double max_duration, double max_length) const {
  std::vector<Sample> kept;
  for (const Sample& s : samples_) {
    const bool beyond = (max_duration > 0.0 && s.time > max_duration) || (max_length > 0.0 && s.distance > max_length);
    if (beyond && kept.size() >= 2) break;
    kept.push_back(s);
  }
  Route out(std::move(kept), waypoints_);
  for (const auto& p : pauses_) {
    if (p.first < out.duration()) out.pauses_.push_back(p);
  }
  return out;
}

Route Route::joined(const std::vector<Route>& parts, double pause) {
  if (parts.empty()) throw Error("joining routes: no route");
  if (!(pause > 0.0)) throw Error("joining routes: the pause between them must be positive");
  std::vector<Sample> samples;
  std::vector<Eigen::Vector2d> waypoints;
  std::vector<std::pair<double, double>> pauses;
  double time = 0.0, distance = 0.0;
  for (const Route& part : parts) {
    if (!samples.empty()) {
      pauses.emplace_back(samples.back().time, samples.back().time + pause);
      time = samples.back().time + pause;
      distance = samples.back().distance;
    }
    for (const auto& p : part.pauses_) pauses.emplace_back(time + p.first, time + p.second);
    for (const Sample& s : part.samples_) samples.push_back({time + s.time, distance + s.distance, s.world_T_base});
    waypoints.insert(waypoints.end(), part.waypoints_.begin(), part.waypoints_.end());
  }
  Route out(std::move(samples), std::move(waypoints));
  out.pauses_ = std::move(pauses);
  return out;
}

bool Route::overlaps_pause(double t0, double t1) const {
  return std::any_of(pauses_.begin(), pauses_.end(),
                     [&](const std::pair<double, double>& p) { return t0 <= p.second && p.first <= t1; });
}

Route plan_route(const TraversabilityGrid& grid, const RayCaster& scene, const RobotModel& robot, RouteKind kind,
                 std::uint64_t seed, double min_length, const RouteRequest& request) {
  Rng rng(mix_key(seed, kind == RouteKind::mapping ? 1 : 2));
  const bool test = kind == RouteKind::test;
  std::optional<int> start;
  if (test && request.start) start = snap_to_free(grid, request.start->head<2>(), "route start");
  std::vector<int> stops;
  if (!test) {
    stops = mapping_waypoints(grid, request.coverage_radius, rng);
  } else if (!request.waypoints.empty()) {
    if (start) stops.push_back(*start);
    for (std::size_t k = 0; k < request.waypoints.size(); ++k) {
      stops.push_back(snap_to_free(grid, request.waypoints[k], "waypoint " + std::to_string(k + 1)));
    }
  } else {
    std::optional<int> landmark;
    if (request.landmark) landmark = snap_to_free(grid, *request.landmark, "landmark viewpoint");
    stops = test_waypoints(grid, rng, min_length, start, landmark, request.via_ramp);
  }
  if (stops.size() < 2) throw Error("route planning: a route needs two places to drive between");

  std::vector<Vector2d> path{grid.center(stops[0])};
  std::vector<bool> fixed{true};
  for (std::size_t k = 0; k + 1 < stops.size(); ++k) {
    const std::vector<int> leg = astar(grid, robot, stops[k], stops[k + 1]);
    for (std::size_t i = 1; i < leg.size(); ++i) {
      path.push_back(grid.center(leg[i]));
      fixed.push_back(i + 1 == leg.size());
    }
  }
  if (path.size() < 2) throw Error("route planning: the route's places are all one place");
  smooth(grid, path, fixed);
  std::vector<Vector2d> waypoints;
  for (int s : stops) waypoints.push_back(grid.center(s));
  std::vector<Vector2d> points = resample(path, kSampleSpacing);
  std::optional<double> initial_yaw;
  if (start) {
    initial_yaw = request.start->z();
    points.insert(points.begin(), points.front());
  }
  return Route(drive(grid, scene, robot, points, initial_yaw), std::move(waypoints));
}

}  // namespace tsdf_mcl::sim
