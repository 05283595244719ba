#include "tsdf_mcl/filter/scan_fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tsdf_mcl/sensor/endpoint_kernel.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

double inlier_ratio(const TsdfMap& map, const Pose& pose, const std::vector<Eigen::Vector3f>& points,
                    float max_distance) {
  if (points.empty() || map.empty()) return 0.0;
  // The sensor update's own lookup (nearest voxel, same float arithmetic), so "near a surface" means what
  // the likelihood saw.
  const kernel::MapView view(map);
  const Eigen::Quaternionf q(Eigen::Quaterniond(pose.linear()).cast<float>());
  float r[9];
  kernel::rotation_matrix(q.w(), q.x(), q.y(), q.z(), r);
  const Eigen::Vector3f tf = pose.translation().cast<float>();
  const float t[3] = {tf.x(), tf.y(), tf.z()};
  const auto limit = static_cast<std::int32_t>(std::ceil(max_distance / view.quant_step));
  std::size_t inliers = 0;
  for (const Eigen::Vector3f& p : points) {
    float g[3];
    kernel::to_grid(r, t, view.inv_voxel, p.x(), p.y(), p.z(), g);
    const std::int32_t v = kernel::sample_nearest(view, g);
    if (v != TsdfMap::kUnknownValue && std::abs(v) <= limit) ++inliers;
  }
  return static_cast<double>(inliers) / static_cast<double>(points.size());
}

namespace {

// Below this many points a scan's rays are marched on one thread: a parallel region costs more than it saves.
constexpr std::ptrdiff_t kParallelPoints = 256;

// A ray from the sensor to a scan point's endpoint through the map, in grid units (ray_fit). `direction` is grid
// units per metre along the ray, so that distances along it count metres.
struct Ray {
  const kernel::MapView& view;
  float voxel;
  std::int32_t inside_limit;  // this deep inside a surface, the ray has gone through it
  std::int32_t front_rise;    // a fall along the ray larger than the map's noise
  Eigen::Vector3f origin;
  Eigen::Vector3f direction;

  std::int32_t value_at(const Eigen::Vector3f& g) const {
    const float gg[3] = {g.x(), g.y(), g.z()};
    return kernel::sample_nearest(view, gg);
  }

  // The inside of a surface (a negative distance) at `at` was entered from the surface's front if the distance
  // three voxels nearer the sensor is larger by more than the map's noise (the distance falls along the ray; over
  // three voxels because a wall's far side holds a flat plateau of its near face's band, where neighbouring voxels
  // differ by noise either way). From its back it grows along the ray: the far face of a wall the map saw from the
  // other side only, its band reaching through the wall into a room the mapping run never entered. A LiDAR never
  // sees a face from behind, so only a front entry is evidence: at a wrong pose a ray passing into a wall crosses
  // the face the map holds.
  bool entered_from_front(const Eigen::Vector3f& at, std::int32_t v) const {
    const std::int32_t nearer = value_at(at - 3.0f * voxel * direction);
    return nearer != TsdfMap::kUnknownValue && nearer > v + front_rise;
  }

  // Where (m along the ray) the ray leaves the block that holds `at`, if that block is all unknown (no block of the
  // map's pool there, or space beyond the map's box); `s` otherwise. Nothing in such a block can stop the march, and a
  // voxel at a time through it is most of a ray's cost where the map is sparse (open air, a room the map lacks).
  float past_unknown_block(const Eigen::Vector3f& at, float s) const {
    std::int32_t r[3];
    bool inside_box = true;
    for (int a = 0; a < 3; ++a) {
      r[a] = kernel::floor_int(at[a] + 0.5f) - view.min_voxel[a];
      inside_box = inside_box && r[a] >= 0 && static_cast<std::uint32_t>(r[a]) < view.dims_voxels[a];
    }
    if (inside_box) {
      const std::uint32_t cell = (static_cast<std::uint32_t>(r[0]) >> 3) +
                                 view.dims_blocks[0] * ((static_cast<std::uint32_t>(r[1]) >> 3) +
                                                        view.dims_blocks[1] * (static_cast<std::uint32_t>(r[2]) >> 3));
      if (view.coarse[cell] != TsdfMap::kUnknownBlock) return s;
    }
    float exit = std::numeric_limits<float>::infinity();
    for (int a = 0; a < 3; ++a) {
      if (direction[a] == 0.0f) continue;
      const std::int32_t first = (r[a] >> 3) * TsdfMap::kBlockSize;  // arithmetic shift: floor for negatives too
      const float low = static_cast<float>(first + view.min_voxel[a]) - 0.5f;
      const float bound = direction[a] > 0.0f ? low + static_cast<float>(TsdfMap::kBlockSize) : low;
      exit = std::min(exit, (bound - origin[a]) / direction[a]);
    }
    // Just past the face, so that the next sample lies in the next block.
    return std::isfinite(exit) ? std::max(s, exit + 0.01f * voxel) : s;
  }

  // Whether the ray goes through a surface it entered from the front before `stop` (m). Sets *met_surface if it
  // met the inside of one on its way: then an endpoint in unknown space lies behind a surface the map has, and is
  // a miss, not unobserved.
  bool passes_through(float stop, bool* met_surface) const {
    // Sphere tracing in metres along the ray: the map's distance (a lower bound on the way to a surface, up to
    // the projective TSDF's errors, hence the factor) where known and positive, a voxel otherwise, a block at a time
    // where the map holds none.
    bool inside = false;      // in a negative region since the last sample
    bool from_front = false;  // ... which the ray entered from the front
    for (float s = 0.0f; s < stop;) {
      const Eigen::Vector3f at = origin + s * direction;
      const std::int32_t v = value_at(at);
      if (v == TsdfMap::kUnknownValue || v >= 0) {
        inside = false;
        s = v == TsdfMap::kUnknownValue ? std::max(s + voxel, past_unknown_block(at, s))
                                        : s + std::max(voxel, 0.8f * static_cast<float>(v) * view.quant_step);
        continue;
      }
      if (!inside) from_front = entered_from_front(at, v);
      inside = true;
      if (from_front) {
        *met_surface = true;
        if (v <= inside_limit) return true;
      }
      s += voxel;
    }
    return false;
  }

  // Whether a surface entered from its front lies just in front of an endpoint in unknown space: the last
  // end_margin before it, voxel by voxel backwards, up to the first known voxel.
  bool surface_before_end(const Eigen::Vector3f& end, float length, float end_margin) const {
    for (float s = voxel; s <= end_margin + 0.5f * voxel && s < length; s += voxel) {
      const Eigen::Vector3f at = end - s * direction;
      const std::int32_t v = value_at(at);
      if (v != TsdfMap::kUnknownValue) return v < 0 && entered_from_front(at, v);
    }
    return false;
  }
};

// A pose as the sensor update applies it: the float rotation and translation of kernel::to_grid, and the sensor's
// position in grid units.
struct GridPose {
  float r[9];
  float t[3];
  Eigen::Vector3f origin;

  GridPose(const Pose& pose, const kernel::MapView& view) {
    const Eigen::Quaternionf q(Eigen::Quaterniond(pose.linear()).cast<float>());
    kernel::rotation_matrix(q.w(), q.x(), q.y(), q.z(), r);
    const Eigen::Vector3f tf = pose.translation().cast<float>();
    t[0] = tf.x();
    t[1] = tf.y();
    t[2] = tf.z();
    origin = tf * view.inv_voxel;
  }
};

}  // namespace

RayFit ray_fit(const TsdfMap& map, const Pose& pose, const std::vector<Eigen::Vector3f>& points, float max_distance,
               float end_margin, std::vector<std::uint8_t>* observed) {
  RayFit fit;
  fit.points = points.size();
  if (observed) observed->assign(points.size(), 0);
  if (points.empty() || map.empty()) return fit;
  const kernel::MapView view(map);
  const float voxel = map.voxel_size();
  const auto near_limit = static_cast<std::int32_t>(std::ceil(max_distance / view.quant_step));
  const auto inside_limit = static_cast<std::int32_t>(std::floor(-2.0f * voxel / view.quant_step));
  const auto front_rise = static_cast<std::int32_t>(std::ceil(0.4f * voxel / view.quant_step));
  const GridPose grid(pose, view);
  // Points are independent and the counts integers: the same fit on any number of threads (one inside a parallel
  // region, where OpenMP does not nest).
  std::size_t see_through = 0, back_faces = 0, observed_points = 0, inliers = 0;
  const auto count = static_cast<std::ptrdiff_t>(points.size());
#pragma omp parallel for schedule(dynamic, 32) reduction(+ : see_through, back_faces, observed_points, inliers) \
    if (count >= kParallelPoints)
  for (std::ptrdiff_t ii = 0; ii < count; ++ii) {
    const auto i = static_cast<std::size_t>(ii);
    const Eigen::Vector3f& p = points[i];
    // The endpoint as the sensor update computes it, so that "inlier" means what the likelihood saw.
    float g[3];
    kernel::to_grid(grid.r, grid.t, view.inv_voxel, p.x(), p.y(), p.z(), g);
    const Eigen::Vector3f end(g[0], g[1], g[2]);
    const std::int32_t at_end = kernel::sample_nearest(view, g);
    const float length = p.norm();
    // Grid units per metre along the ray.
    const Eigen::Vector3f direction =
        length > 0.0f ? Eigen::Vector3f((end - grid.origin) / length) : Eigen::Vector3f::Zero();
    const Ray ray{view, voxel, inside_limit, front_rise, grid.origin, direction};
    bool met_surface = false;  // the ray met the inside of a surface on its way (Ray::passes_through)
    const bool through = length > end_margin && ray.passes_through(length - end_margin, &met_surface);
    if (through) ++see_through;
    bool evidence = through;
    if (at_end != TsdfMap::kUnknownValue) {
      // An endpoint inside a surface reached from its back is unobserved (Ray::entered_from_front), however near
      // the face: it lies on the far face of a wall, which the map does not hold. One in free space is evidence.
      evidence =
          evidence || met_surface || at_end >= 0 || length <= 3.0f * voxel || ray.entered_from_front(end, at_end);
      if (!evidence) ++back_faces;
    } else {
      evidence = evidence || met_surface || ray.surface_before_end(end, length, end_margin);
    }
    if (!evidence) continue;
    ++observed_points;
    if (observed) (*observed)[i] = 1;
    if (at_end != TsdfMap::kUnknownValue && std::abs(at_end) <= near_limit) ++inliers;
  }
  fit.see_through = see_through;
  fit.back_faces = back_faces;
  fit.observed = observed_points;
  fit.inliers = inliers;
  return fit;
}

PairedEvidence paired_evidence(const std::vector<double>& log_a, const std::vector<std::uint8_t>& observed_a,
                               const std::vector<double>& log_b, const std::vector<std::uint8_t>& observed_b,
                               double dead_band) {
  PairedEvidence e;
  const std::size_t n = std::min({log_a.size(), log_b.size(), observed_a.size(), observed_b.size()});
  for (std::size_t i = 0; i < n; ++i) {
    if (!observed_a[i] || !observed_b[i]) continue;
    const double d = log_a[i] - log_b[i];
    e.sum += std::copysign(std::max(std::abs(d) - dead_band, 0.0), d);
    ++e.shared;
  }
  return e;
}

PointEvidence point_evidence(const TsdfMap& map, const EndpointModel& model, const Pose& pose,
                             const std::vector<Eigen::Vector3f>& points, float inlier_distance, float frontier_reach) {
  PointEvidence e;
  const Eigen::Quaternionf q(Eigen::Quaterniond(pose.linear()).cast<float>());
  point_log_likelihoods(map, model, pose.translation().cast<float>(), q, points, e.log);
  e.fit = ray_fit(map, pose, points, inlier_distance, 0.4f, &e.observed);
  if (frontier_reach > 0.0f) drop_frontier_points(map, pose, points, frontier_reach, e.observed);
  return e;
}

namespace {

// An endpoint in unknown space is a miss where its ray went into a surface the map holds and on beyond its band. Where
// the ray was in observed free space within the band's depth before it (a positive distance, before any voxel deep
// inside a surface), the endpoint sits in a hole of a surface the map saw only at a grazing angle (a skipped room's
// ceiling seen through its door: the surface's own voxels unknown, those beside them known), or where the observed
// free space ends. The map cannot say whether a surface is there.
bool in_a_hole(const kernel::MapView& view, const float g[3], const Eigen::Vector3f& direction, float range,
               float voxel, float truncation, std::int32_t near_surface) {
  if (kernel::sample_nearest(view, g) != TsdfMap::kUnknownValue) return false;
  for (float back = voxel; back <= truncation + 0.5f * voxel && back < range; back += voxel) {
    const float h[3] = {g[0] - back * direction.x(), g[1] - back * direction.y(), g[2] - back * direction.z()};
    const std::int32_t v = kernel::sample_nearest(view, h);
    if (v == TsdfMap::kUnknownValue) continue;
    if (v <= -near_surface) return false;
    if (v > 0) return true;
  }
  return false;
}

}  // namespace

std::size_t drop_frontier_points(const TsdfMap& map, const Pose& pose, const std::vector<Eigen::Vector3f>& points,
                                 float reach, std::vector<std::uint8_t>& observed) {
  if (points.empty() || map.empty() || !(reach > 0.0f)) return 0;
  const kernel::MapView view(map);
  const float truncation = map.truncation();
  const float voxel = map.voxel_size();
  const auto near_surface = static_cast<std::int32_t>(0.5f * truncation / view.quant_step);
  const GridPose grid(pose, view);
  const float reach_grid = reach * view.inv_voxel;
  std::size_t dropped = 0;
  const auto count = static_cast<std::ptrdiff_t>(std::min(points.size(), observed.size()));
#pragma omp parallel for schedule(static) reduction(+ : dropped) if (count >= kParallelPoints)
  for (std::ptrdiff_t jj = 0; jj < count; ++jj) {
    const auto j = static_cast<std::size_t>(jj);
    if (!observed[j]) continue;
    const float range = points[j].norm();
    if (!(range > 0.0f)) continue;
    float g[3];
    kernel::to_grid(grid.r, grid.t, view.inv_voxel, points[j].x(), points[j].y(), points[j].z(), g);
    const Eigen::Vector3f direction = (Eigen::Vector3f(g[0], g[1], g[2]) - grid.origin) / range;  // grid units per m
    const auto seen = [&](const float at[3]) {
      if (kernel::sample_nearest(view, at) != TsdfMap::kUnknownValue) return true;
      for (int k = 1; k <= 3; ++k) {
        const float back = static_cast<float>(k) * truncation;
        if (back >= range) break;
        const float h[3] = {at[0] - back * direction.x(), at[1] - back * direction.y(), at[2] - back * direction.z()};
        const std::int32_t v = kernel::sample_nearest(view, h);
        if (v != TsdfMap::kUnknownValue) return v < near_surface;
      }
      return false;
    };
    bool frontier = in_a_hole(view, g, direction, range, voxel, truncation, near_surface);
    for (int a = 0; a < 3 && !frontier; ++a) {
      for (const float sign : {-1.0f, 1.0f}) {
        float at[3] = {g[0], g[1], g[2]};
        at[a] += sign * reach_grid;
        if (!seen(at)) {
          frontier = true;
          break;
        }
      }
    }
    if (frontier) {
      observed[j] = 0;
      ++dropped;
    }
  }
  return dropped;
}

WallTilt select_walls(const std::vector<Eigen::Vector3f>& normals, const Pose& world_T_sensor,
                      const Eigen::Vector3d& world_up, double information_per_wall, std::size_t full_walls) {
  constexpr std::size_t kMinWalls = 30;
  WallTilt walls;
  walls.world_up = world_up.normalized();
  if (!(information_per_wall > 0.0)) return walls;
  const Eigen::Vector3d up_in_sensor = world_T_sensor.linear().transpose() * walls.world_up;
  constexpr double kSinTolerance = 0.17364817766693033;  // sin 10°
  for (const Eigen::Vector3f& n : normals) {
    const Eigen::Vector3d u = n.cast<double>().normalized();
    if (std::abs(u.dot(up_in_sensor)) < kSinTolerance) walls.normals.push_back(u);
  }
  if (walls.normals.size() < kMinWalls) {
    walls.normals.clear();
    return walls;
  }
  walls.information =
      information_per_wall * std::min(1.0, static_cast<double>(full_walls) / static_cast<double>(walls.normals.size()));
  return walls;
}

namespace {

// The map's distance at grid position g (trilinear, renormalized over the known corners as kernel::sample_trilinear)
// and its gradient (per grid unit), from one read of the cell's eight corners; false where they are all unknown.
bool distance_and_gradient(const kernel::MapView& view, const float g[3], float* distance, Eigen::Vector3f* gradient) {
  const std::int32_t ix = kernel::floor_int(g[0]), iy = kernel::floor_int(g[1]), iz = kernel::floor_int(g[2]);
  const float f[3] = {g[0] - static_cast<float>(ix), g[1] - static_cast<float>(iy), g[2] - static_cast<float>(iz)};
  float weight = 0.0f, sum = 0.0f;
  Eigen::Vector3f d_weight = Eigen::Vector3f::Zero(), d_sum = Eigen::Vector3f::Zero();
  for (int corner = 0; corner < 8; ++corner) {
    const int c[3] = {corner & 1, (corner >> 1) & 1, (corner >> 2) & 1};
    const std::int32_t q = view.fetch(ix + c[0], iy + c[1], iz + c[2]);
    if (q == TsdfMap::kUnknownValue) continue;
    float w[3];
    for (int a = 0; a < 3; ++a) w[a] = c[a] ? f[a] : 1.0f - f[a];
    const float corner_weight = w[0] * w[1] * w[2];
    // d(corner_weight)/d(g[a]): the factor of axis a turned into its slope, +1 or -1.
    const Eigen::Vector3f slope((c[0] ? 1.0f : -1.0f) * w[1] * w[2], (c[1] ? 1.0f : -1.0f) * w[0] * w[2],
                                (c[2] ? 1.0f : -1.0f) * w[0] * w[1]);
    const auto value = static_cast<float>(q);
    weight += corner_weight;
    sum += corner_weight * value;
    d_weight += slope;
    d_sum += slope * value;
  }
  if (weight < 1e-3f) return false;
  *distance = sum / weight * view.quant_step;
  *gradient = (d_sum * weight - d_weight * sum) / (weight * weight) * view.quant_step;
  return true;
}

}  // namespace

namespace {

// The Gauss-Newton normal equations of the points' distances at `pose` (Huber-weighted beyond 0.1 m; points in unknown
// space or beyond 0.8 of the truncation band take no part); returns how many points took part.
std::size_t point_normal_equations(const kernel::MapView& view, float band, const Pose& pose,
                                   const std::vector<Eigen::Vector3f>& points, Eigen::Matrix<double, 6, 6>& jtj,
                                   Eigen::Matrix<double, 6, 1>& jtr) {
  constexpr double kHuber = 0.1;  // m
  jtj.setZero();
  jtr.setZero();
  std::size_t used = 0;
  const Eigen::Matrix3f r = pose.linear().cast<float>();
  const Eigen::Vector3f t = pose.translation().cast<float>();
  for (const Eigen::Vector3f& p : points) {
    const Eigen::Vector3f w = r * p + t;
    const float g[3] = {w.x() * view.inv_voxel, w.y() * view.inv_voxel, w.z() * view.inv_voxel};
    float d = 0.0f;
    Eigen::Vector3f grad;
    if (!distance_and_gradient(view, g, &d, &grad) || std::abs(d) > band) continue;
    grad *= view.inv_voxel;  // per metre
    // Rotation about the sensor, not the map's origin (tens of metres away, where a small turn is a large shift):
    // d(w') for w' = t + dt + (1 + [dtheta]x) R p, so the Jacobian is [grad, (R p) x grad].
    Eigen::Matrix<double, 6, 1> j;
    j.head<3>() = grad.cast<double>();
    j.tail<3>() = (r * p).cast<double>().cross(grad.cast<double>());
    const double weight = std::abs(d) <= kHuber ? 1.0 : kHuber / std::abs(d);
    jtj.selfadjointView<Eigen::Lower>().rankUpdate(j, weight);
    jtr += weight * j * static_cast<double>(d);
    ++used;
  }
  jtj = jtj.selfadjointView<Eigen::Lower>();
  return used;
}

}  // namespace

Pose refine_pose(const TsdfMap& map, const Pose& pose, const std::vector<Eigen::Vector3f>& points, int iterations,
                 const WallTilt* walls) {
  if (points.empty() || map.empty()) return pose;
  const kernel::MapView view(map);
  const float band = 0.8f * map.truncation();
  // A step this small changes nothing the filter measures: the refinement has settled.
  constexpr double kSettledM = 5e-4;
  constexpr double kSettledRad = 2e-4;
  Pose current = pose;
  for (int iteration = 0; iteration < iterations; ++iteration) {
    Eigen::Matrix<double, 6, 6> jtj;
    Eigen::Matrix<double, 6, 1> jtr;
    if (point_normal_equations(view, band, current, points, jtj, jtr) < 12) return current;
    if (walls != nullptr && walls->information > 0.0) {
      // e = u . (R n); turning by dtheta adds u . (dtheta x R n) = dtheta . (R n x u).
      for (const Eigen::Vector3d& n : walls->normals) {
        const Eigen::Vector3d seen = current.linear() * n;
        const Eigen::Vector3d j = seen.cross(walls->world_up);
        jtj.bottomRightCorner<3, 3>() += walls->information * j * j.transpose();
        jtr.tail<3>() += walls->information * j * walls->world_up.dot(seen);
      }
    }
    // Levenberg-Marquardt damping: the directions few points constrain (a level LiDAR's roll and pitch) move
    // little rather than wildly.
    Eigen::Matrix<double, 6, 6> damped = jtj;
    damped.diagonal() += 0.05 * jtj.diagonal() + Eigen::Matrix<double, 6, 1>::Constant(1e-6);
    const Eigen::Matrix<double, 6, 1> delta = -damped.ldlt().solve(jtr);
    if (!delta.allFinite()) return current;
    // Steps beyond 0.1 m or 2° would leave the region the linearization describes; each part on its own, so that
    // a poorly held rotation does not stall the translation.
    Eigen::Matrix<double, 6, 1> applied = delta;
    if (applied.head<3>().norm() > 0.1) applied.head<3>() *= 0.1 / applied.head<3>().norm();
    if (applied.tail<3>().norm() > 0.035) applied.tail<3>() *= 0.035 / applied.tail<3>().norm();
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(applied.tail<3>().norm(),
                          applied.tail<3>().norm() > 0.0 ? applied.tail<3>().normalized() : Eigen::Vector3d::UnitZ())
            .toRotationMatrix();
    Pose next = Pose::Identity();
    next.linear() = turn * current.linear();
    next.translation() = current.translation() + applied.head<3>();
    current = next;
    if (applied.head<3>().norm() < kSettledM && applied.tail<3>().norm() < kSettledRad) break;
  }
  return current;
}

}  // namespace tsdf_mcl
