#include "tsdf_mcl/sim/traversability.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <queue>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::sim {

namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr int kNeighbours[8][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}, {1, 1}, {1, -1}, {-1, 1}, {-1, -1}};

// Squared Euclidean distance transform of one line (Felzenszwalb & Huttenlocher): f holds 0 at sources and
// a large value elsewhere; d receives min_q (p - q)^2 + f(q). v and z are scratch space (n and n + 1).
void distance_transform_1d(const std::vector<double>& f, std::vector<double>& d, std::vector<int>& v,
                           std::vector<double>& z) {
  const int n = static_cast<int>(f.size());
  auto intersection = [&](int q, int p) {
    return ((f[q] + static_cast<double>(q) * q) - (f[p] + static_cast<double>(p) * p)) / (2.0 * (q - p));
  };
  int k = 0;
  v[0] = 0;
  z[0] = -std::numeric_limits<double>::infinity();
  z[1] = std::numeric_limits<double>::infinity();
  for (int q = 1; q < n; ++q) {
    double s = intersection(q, v[k]);
    while (s <= z[k]) s = intersection(q, v[--k]);
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = std::numeric_limits<double>::infinity();
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[k + 1] < q) ++k;
    const double dq = q - v[k];
    d[q] = dq * dq + f[v[k]];
  }
}

// z range of the part of triangle (a, b, c) above the square [x0, x1] x [y0, y1]; false if it misses.
bool clipped_z_range(const std::array<Eigen::Vector3f, 3>& tri, float x0, float x1, float y0, float y1, float& zmin,
                     float& zmax) {
  std::array<Eigen::Vector3f, 8> poly{}, next{};
  int n = 3;
  for (int i = 0; i < 3; ++i) poly[i] = tri[i];
  // Keep the side where sign * (p[axis] - bound) >= 0.
  const struct {
    int axis;
    float bound;
    float sign;
  } planes[4] = {{0, x0, 1.0f}, {0, x1, -1.0f}, {1, y0, 1.0f}, {1, y1, -1.0f}};
  for (const auto& pl : planes) {
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3f& p = poly[i];
      const Eigen::Vector3f& q = poly[(i + 1) % n];
      const float dp = pl.sign * (p[pl.axis] - pl.bound);
      const float dq = pl.sign * (q[pl.axis] - pl.bound);
      if (dp >= 0.0f) next[m++] = p;
      if ((dp >= 0.0f) != (dq >= 0.0f)) next[m++] = p + (q - p) * (dp / (dp - dq));
    }
    n = m;
    if (n == 0) return false;
    poly = next;
  }
  zmin = std::numeric_limits<float>::infinity();
  zmax = -zmin;
  for (int i = 0; i < n; ++i) {
    zmin = std::min(zmin, poly[i].z());
    zmax = std::max(zmax, poly[i].z());
  }
  return true;
}

}  // namespace

TraversabilityGrid::TraversabilityGrid(const RayCaster& scene, const TriangleMesh& mesh, const RobotModel& robot,
                                       double cell, double min_floor_z, bool open_air)
    : cell_(cell) {
  const Eigen::AlignedBox3f box = scene.bounds();
  origin_ = box.min().head<2>().cast<double>() - Eigen::Vector2d(cell, cell);
  width_ = static_cast<int>(std::ceil(static_cast<double>(box.sizes().x()) / cell)) + 2;
  height_ = static_cast<int>(std::ceil(static_cast<double>(box.sizes().y()) / cell)) + 2;
  if (static_cast<double>(width_) * height_ > 2e7) {
    char msg[160];
    std::snprintf(msg, sizeof(msg), "mesh footprint %.0f x %.0f m is too large for the %.2f m traversability grid",
                  static_cast<double>(box.sizes().x()), static_cast<double>(box.sizes().y()), cell);
    throw Error(msg);
  }
  const auto n = static_cast<std::size_t>(width_) * static_cast<std::size_t>(height_);
  floor_.assign(n, kNaN);
  slope_deg_.assign(n, kNaN);

  find_floors(scene, robot, min_floor_z);
  const std::size_t floor_cells = mark_passable(find_obstacles(mesh, robot));
  const std::vector<std::uint8_t> blocked = find_blocked(robot.max_step);
  compute_clearance(blocked);
  // The obstacle may sit anywhere in its cell: half a cell of margin.
  const auto needed = static_cast<float>(robot.radius + 0.5 * cell);
  // In the open air no region is enclosed: the largest one wins.
  choose_free_region(
      blocked, needed,
      open_air ? std::vector<std::uint8_t>(floor_.size(), 0) : find_enclosed(scene, robot, blocked, needed));
  if (free_area() < 1.0) {
    char msg[256];
    std::snprintf(msg, sizeof(msg),
                  "the mesh has no traversable floor: %.1f m^2 of floor (near-horizontal, %.1f m headroom), %.1f m^2 "
                  "where a robot of radius %.2f m fits",
                  static_cast<double>(floor_cells) * cell * cell, robot.height, free_area(), robot.radius);
    throw Error(msg);
  }
}

void TraversabilityGrid::find_floors(const RayCaster& scene, const RobotModel& robot, double min_floor_z) {
  // Floors: every surface under the cell centre, top down.
  const float top = scene.bounds().max().z() + 1.0f;
  const auto cos_max_slope = static_cast<float>(std::cos(robot.max_slope_deg * M_PI / 180.0));
  const auto robot_height = static_cast<float>(robot.height);
  const Eigen::Vector3f down(0.0f, 0.0f, -1.0f);
#pragma omp parallel for schedule(dynamic, 8)
  for (int iy = 0; iy < height_; ++iy) {
    for (int ix = 0; ix < width_; ++ix) {
      const int i = index(ix, iy);
      const Eigen::Vector2d c = center(i);
      const Eigen::Vector3f origin(static_cast<float>(c.x()), static_cast<float>(c.y()), top);
      float above = std::numeric_limits<float>::infinity();
      float tnear = 0.0f;
      for (int k = 0; k < 64; ++k) {
        const RayCaster::Hit hit = scene.cast(origin, down, std::numeric_limits<float>::infinity(), tnear);
        if (!hit.hit()) break;
        const float z = top - hit.distance;
        const float nz = std::abs(hit.normal.z());
        if (nz >= cos_max_slope && z >= min_floor_z && above - z >= robot_height) {
          floor_[i] = z;
          slope_deg_[i] = static_cast<float>(std::acos(std::min(1.0f, nz)) * 180.0 / M_PI);
        }
        above = z;
        tnear = hit.distance + 1e-4f;
      }
    }
  }
}

std::vector<std::uint8_t> TraversabilityGrid::find_obstacles(const TriangleMesh& mesh, const RobotModel& robot) const {
  // Obstacles: any triangle reaching into the band between a step and the robot's height above the floor.
  float lowest = std::numeric_limits<float>::infinity(), highest = -lowest;
  for (float f : floor_) {
    if (std::isnan(f)) continue;
    lowest = std::min(lowest, f);
    highest = std::max(highest, f);
  }
  const auto step = static_cast<float>(robot.max_step);
  std::vector<std::uint8_t> obstacle(floor_.size(), 0);
  const auto cellf = static_cast<float>(cell_);
  const auto robot_height = static_cast<float>(robot.height);
  for (const auto& t : mesh.triangles) {
    const std::array<Eigen::Vector3f, 3> tri{mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]};
    const float tz0 = std::min({tri[0].z(), tri[1].z(), tri[2].z()});
    const float tz1 = std::max({tri[0].z(), tri[1].z(), tri[2].z()});
    if (tz1 <= lowest + step || tz0 >= highest + robot_height) continue;
    auto cell_range = [&](int axis, int count) {
      const float lo = std::min({tri[0][axis], tri[1][axis], tri[2][axis]});
      const float hi = std::max({tri[0][axis], tri[1][axis], tri[2][axis]});
      const double o = origin_[axis];
      return std::pair<int, int>{std::max(0, static_cast<int>(std::floor((lo - o) / cell_))),
                                 std::min(count - 1, static_cast<int>(std::floor((hi - o) / cell_)))};
    };
    const auto [ix0, ix1] = cell_range(0, width_);
    const auto [iy0, iy1] = cell_range(1, height_);
    for (int iy = iy0; iy <= iy1; ++iy) {
      for (int ix = ix0; ix <= ix1; ++ix) {
        const int i = index(ix, iy);
        const float f = floor_[i];
        if (std::isnan(f) || obstacle[i] || tz1 <= f + step || tz0 >= f + robot_height) continue;
        const float x0 = static_cast<float>(origin_.x()) + ix * cellf;
        const float y0 = static_cast<float>(origin_.y()) + iy * cellf;
        float zmin, zmax;
        if (clipped_z_range(tri, x0, x0 + cellf, y0, y0 + cellf, zmin, zmax) && zmax > f + step &&
            zmin < f + robot_height) {
          obstacle[i] = 1;
        }
      }
    }
  }
  return obstacle;
}

std::size_t TraversabilityGrid::mark_passable(const std::vector<std::uint8_t>& obstacle) {
  passable_.assign(floor_.size(), 0);
  std::size_t floor_cells = 0;
  for (std::size_t i = 0; i < floor_.size(); ++i) {
    floor_cells += !std::isnan(floor_[i]);
    passable_[i] = !std::isnan(floor_[i]) && !obstacle[i];
  }
  return floor_cells;
}

std::vector<std::uint8_t> TraversabilityGrid::find_blocked(double max_step) const {
  const auto step = static_cast<float>(max_step);
  // Blocked: no passable floor, or a cliff to a neighbour (missing floor or a step too high).
  std::vector<std::uint8_t> blocked(floor_.size(), 1);
  for (int iy = 1; iy + 1 < height_; ++iy) {
    for (int ix = 1; ix + 1 < width_; ++ix) {
      const int i = index(ix, iy);
      if (!passable_[i]) continue;
      bool cliff = false;
      for (const auto& d : kNeighbours) {
        const float g = floor_[index(ix + d[0], iy + d[1])];
        cliff = cliff || std::isnan(g) || std::abs(g - floor_[i]) > step;
      }
      blocked[i] = cliff;
    }
  }
  return blocked;
}

void TraversabilityGrid::compute_clearance(const std::vector<std::uint8_t>& blocked) {
  // Clearance: distance transform of the blocked cells, columns then rows.
  const std::size_t n = floor_.size();
  std::vector<double> sq(n);
  for (std::size_t i = 0; i < n; ++i) sq[i] = blocked[i] ? 0.0 : 1e18;
  {
    const int longest = std::max(width_, height_);
    std::vector<double> f, d;
    std::vector<int> v(longest);
    std::vector<double> z(longest + 1);
    f.resize(height_);
    d.resize(height_);
    for (int ix = 0; ix < width_; ++ix) {
      for (int iy = 0; iy < height_; ++iy) f[iy] = sq[index(ix, iy)];
      distance_transform_1d(f, d, v, z);
      for (int iy = 0; iy < height_; ++iy) sq[index(ix, iy)] = d[iy];
    }
    f.resize(width_);
    d.resize(width_);
    for (int iy = 0; iy < height_; ++iy) {
      for (int ix = 0; ix < width_; ++ix) f[ix] = sq[index(ix, iy)];
      distance_transform_1d(f, d, v, z);
      for (int ix = 0; ix < width_; ++ix) sq[index(ix, iy)] = d[ix];
    }
  }
  clearance_.resize(n);
  for (std::size_t i = 0; i < n; ++i) clearance_[i] = static_cast<float>(std::sqrt(sq[i]) * cell_);
}

bool TraversabilityGrid::candidate(const std::vector<std::uint8_t>& blocked, float needed, std::size_t i) const {
  return !blocked[i] && clearance_[i] >= needed;
}

std::vector<std::uint8_t> TraversabilityGrid::find_enclosed(const RayCaster& scene, const RobotModel& robot,
                                                            const std::vector<std::uint8_t>& blocked,
                                                            float needed) const {
  // Enclosure, sampled on every third cell: horizontal rays at half the robot's height hit the mesh in
  // (nearly) every direction indoors, but not beside a building standing on a ground plane.
  const float reach = scene.bounds().sizes().norm();
  const auto robot_height = static_cast<float>(robot.height);
  std::vector<std::uint8_t> enclosed(floor_.size(), 0);
#pragma omp parallel for schedule(dynamic, 4)
  for (int iy = 0; iy < height_; iy += 3) {
    for (int ix = 0; ix < width_; ix += 3) {
      const int i = index(ix, iy);
      if (!candidate(blocked, needed, static_cast<std::size_t>(i))) continue;
      const Eigen::Vector2d c = center(i);
      const Eigen::Vector3f origin(static_cast<float>(c.x()), static_cast<float>(c.y()), floor_[i] + robot_height / 2);
      int hits = 0;
      for (int k = 0; k < 16; ++k) {
        const double a = 2.0 * M_PI * k / 16.0;
        hits +=
            scene
                .cast(origin, Eigen::Vector3f(static_cast<float>(std::cos(a)), static_cast<float>(std::sin(a)), 0.0f),
                      reach)
                .hit();
      }
      enclosed[i] = hits >= 14;
    }
  }
  return enclosed;
}

void TraversabilityGrid::choose_free_region(const std::vector<std::uint8_t>& blocked, float needed,
                                            const std::vector<std::uint8_t>& enclosed) {
  // Connected regions; the one with the most enclosed cells wins, the larger one among equals.
  const std::size_t n = floor_.size();
  std::vector<int> component(n, -1);
  std::vector<int> best;
  std::size_t best_enclosed = 0;
  for (std::size_t seed = 0; seed < n; ++seed) {
    if (component[seed] >= 0 || !candidate(blocked, needed, seed)) continue;
    std::vector<int> members{static_cast<int>(seed)};
    component[seed] = static_cast<int>(seed);
    std::size_t members_enclosed = 0;
    for (std::size_t head = 0; head < members.size(); ++head) {
      members_enclosed += enclosed[static_cast<std::size_t>(members[head])];
      const Eigen::Vector2i c = coords(members[head]);
      for (const auto& d : kNeighbours) {
        const int j = index(c.x() + d[0], c.y() + d[1]);  // blocked border cells keep this inside the grid
        if (component[j] >= 0 || !candidate(blocked, needed, static_cast<std::size_t>(j))) continue;
        component[j] = static_cast<int>(seed);
        members.push_back(j);
      }
    }
    if (members_enclosed > best_enclosed || (members_enclosed == best_enclosed && members.size() > best.size())) {
      best = std::move(members);
      best_enclosed = members_enclosed;
    }
  }
  free_.assign(n, 0);
  std::sort(best.begin(), best.end());
  for (int i : best) free_[static_cast<std::size_t>(i)] = 1;
  free_cells_ = std::move(best);
}

int TraversabilityGrid::index_of(const Eigen::Vector2d& p) const {
  const Eigen::Vector2d g = (p - origin_) / cell_;
  const int ix = static_cast<int>(std::floor(g.x()));
  const int iy = static_cast<int>(std::floor(g.y()));
  if (ix < 0 || iy < 0 || ix >= width_ || iy >= height_) return -1;
  return index(ix, iy);
}

Eigen::Vector2d TraversabilityGrid::center(int i) const {
  const Eigen::Vector2i c = coords(i);
  return origin_ + (c.cast<double>() + Eigen::Vector2d(0.5, 0.5)) * cell_;
}

void TraversabilityGrid::exclude(const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& areas) {
  if (areas.empty()) return;
  std::vector<int> kept;
  for (int i : free_cells_) {
    const Eigen::Vector2d c = center(i);
    bool inside = false;
    for (const auto& [lo, hi] : areas)
      inside = inside || ((c.array() >= lo.array()).all() && (c.array() <= hi.array()).all());
    if (inside)
      free_[static_cast<std::size_t>(i)] = 0;
    else
      kept.push_back(i);
  }
  free_cells_ = std::move(kept);
  if (free_area() < 1.0) throw Error("the skipped areas leave no traversable floor for the mapping route");
}

}  // namespace tsdf_mcl::sim
