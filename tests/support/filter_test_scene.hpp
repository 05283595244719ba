#pragma once
// A small synthetic world for filter tests: an asymmetric set of rooms made of boxes, its TSDF from exact
// analytic signed distances, LiDAR scans by analytic ray-box casting, a trajectory through the rooms and a
// drifting odometry track. Builds in well under a second.
#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/core/random.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::test {

struct Box {
  Eigen::Vector3f lo;
  Eigen::Vector3f hi;
};

inline Box box(float x0, float y0, float z0, float x1, float y1, float z1) {
  return Box{Eigen::Vector3f(x0, y0, z0), Eigen::Vector3f(x1, y1, z1)};
}

// Three rooms of different sizes joined by doors, with pillars, a cabinet and a table: no two places look
// alike, so global localization has one answer. Interior: x 0..14, y 0..9, z 0..2.6 (floor at z = 0).
inline std::vector<Box> office_boxes() {
  return {
      box(-0.2f, -0.2f, -0.2f, 14.2f, 9.2f, 0.0f),  // floor
      box(-0.2f, -0.2f, 2.6f, 14.2f, 9.2f, 2.8f),   // ceiling
      box(-0.2f, -0.2f, 0.0f, 0.0f, 9.2f, 2.6f),    // west wall
      box(14.0f, -0.2f, 0.0f, 14.2f, 9.2f, 2.6f),   // east wall
      box(-0.2f, -0.2f, 0.0f, 14.2f, 0.0f, 2.6f),   // south wall
      box(-0.2f, 9.0f, 0.0f, 14.2f, 9.2f, 2.6f),    // north wall
      box(6.0f, 0.0f, 0.0f, 6.2f, 3.0f, 2.6f),      // wall between west and south-east room, door y 3..4.2
      box(6.0f, 4.2f, 0.0f, 6.2f, 9.0f, 2.6f),
      box(6.2f, 5.5f, 0.0f, 9.0f, 5.7f, 2.6f),  // wall between the east rooms, door x 9..10.2
      box(10.2f, 5.5f, 0.0f, 14.0f, 5.7f, 2.6f),
      box(2.0f, 6.5f, 0.0f, 2.4f, 6.9f, 2.6f),    // pillar
      box(3.5f, 2.0f, 0.0f, 3.9f, 2.4f, 2.6f),    // pillar
      box(0.0f, 0.0f, 0.0f, 0.6f, 2.2f, 1.9f),    // cabinet in the south-west corner
      box(10.5f, 1.0f, 0.7f, 12.5f, 2.0f, 0.8f),  // table top
      box(10.5f, 1.0f, 0.0f, 10.6f, 2.0f, 0.7f),  // table legs (as panels)
      box(12.4f, 1.0f, 0.0f, 12.5f, 2.0f, 0.7f),
      box(7.0f, 7.8f, 0.0f, 8.5f, 9.0f, 1.2f),    // sideboard
      box(13.0f, 6.5f, 0.0f, 14.0f, 7.0f, 2.0f),  // shelf
  };
}

// Two identical rooms at the ends of a corridor, the building symmetric under a half turn about (12, 4): every
// view from one wing is also the view from the other. The corridor has a niche on each side (each the other's
// image); only the north one holds a cabinet, visible from the corridor between x ~ 9.7 and 12.5 and from
// neither room. Interior x 0..24, y 0..8, z 0..2.6.
inline std::vector<Box> twin_wing_boxes(bool with_feature) {
  const auto box = [](float x0, float y0, float z0, float x1, float y1, float z1) {
    return Box{Eigen::Vector3f(x0, y0, z0), Eigen::Vector3f(x1, y1, z1)};
  };
  std::vector<Box> half = {
      box(-0.2f, -0.2f, -0.2f, 24.2f, 8.2f, 0.0f),  // floor (symmetric by itself)
      box(-0.2f, -0.2f, 2.6f, 24.2f, 8.2f, 2.8f),   // ceiling
      box(-0.2f, -0.2f, 0.0f, 0.0f, 8.2f, 2.6f),    // west wall
      box(-0.2f, -0.2f, 0.0f, 24.2f, 0.0f, 2.6f),   // south wall (the north wall is its image)
      box(6.0f, 0.0f, 0.0f, 6.2f, 3.5f, 2.6f),      // wall of room A, door y 3.5..4.5
      box(6.0f, 4.5f, 0.0f, 6.2f, 8.0f, 2.6f),
      box(6.2f, 5.0f, 0.0f, 10.0f, 5.2f, 2.6f),  // corridor north wall, niche x 10..12
      box(12.0f, 5.0f, 0.0f, 17.8f, 5.2f, 2.6f),
      box(9.8f, 5.2f, 0.0f, 10.0f, 7.0f, 2.6f),  // niche walls
      box(12.0f, 5.2f, 0.0f, 12.2f, 7.0f, 2.6f),
      box(9.8f, 7.0f, 0.0f, 12.2f, 7.2f, 2.6f),
      box(2.0f, 1.5f, 0.0f, 2.4f, 1.9f, 2.6f),  // pillar in room A
      box(0.0f, 6.0f, 0.0f, 0.6f, 8.0f, 1.9f),  // cabinet in room A
      box(3.0f, 5.5f, 0.7f, 4.5f, 6.5f, 0.8f),  // table top in room A
  };
  std::vector<Box> boxes;
  for (const Box& b : half) {
    boxes.push_back(b);
    // The half turn about (12, 4): (x, y) -> (24 - x, 8 - y).
    boxes.push_back(Box{Eigen::Vector3f(24.0f - b.hi.x(), 8.0f - b.hi.y(), b.lo.z()),
                        Eigen::Vector3f(24.0f - b.lo.x(), 8.0f - b.lo.y(), b.hi.z())});
  }
  if (with_feature) boxes.push_back(box(10.3f, 6.3f, 0.0f, 11.7f, 7.0f, 1.5f));  // the one difference
  return boxes;
}

inline float box_distance(const Box& b, const Eigen::Vector3f& p) {
  const Eigen::Vector3f c = 0.5f * (b.lo + b.hi);
  const Eigen::Vector3f h = 0.5f * (b.hi - b.lo);
  const Eigen::Vector3f q = (p - c).cwiseAbs() - h;
  return q.cwiseMax(0.0f).norm() + std::min(q.maxCoeff(), 0.0f);
}

inline float scene_distance(const std::vector<Box>& boxes, const Eigen::Vector3f& p) {
  float d = 1e9f;
  for (const Box& b : boxes) d = std::min(d, box_distance(b, p));
  return d;
}

// Known: within the building's hull [hull_lo, hull_hi], where `observed` says so (what the mapping run saw), and no
// deeper than the truncation band inside a solid. Far free space ends up in free blocks after compaction, as in maps
// built from scans.
// The same from any signed distance function of the world position.
inline TsdfMap make_map_where(const std::function<float(const Eigen::Vector3f&)>& distance,
                              const Eigen::Vector3f& hull_lo, const Eigen::Vector3f& hull_hi,
                              const std::function<bool(const Eigen::Vector3f&)>& observed, float voxel = 0.1f,
                              float truncation = 0.3f) {
  const Eigen::Vector3f margin = Eigen::Vector3f::Constant(0.4f);
  TsdfMap map = TsdfMap::covering(voxel, truncation, hull_lo - margin, hull_hi + margin);
  const Eigen::Vector3i lo = map.min_block() * TsdfMap::kBlockSize;
  const Eigen::Vector3i hi = (map.min_block() + map.dims_blocks()) * TsdfMap::kBlockSize;
  for (int z = lo.z(); z < hi.z(); ++z)
    for (int y = lo.y(); y < hi.y(); ++y)
      for (int x = lo.x(); x < hi.x(); ++x) {
        const Eigen::Vector3f c = map.center_of({x, y, z});
        if ((c.array() < hull_lo.array()).any() || (c.array() > hull_hi.array()).any() || !observed(c)) continue;
        const float d = distance(c);
        if (d < -truncation) continue;
        map.set_distance({x, y, z}, d);
      }
  map.compact();
  return map;
}

inline TsdfMap make_box_map_where(const std::vector<Box>& boxes, const Eigen::Vector3f& hull_lo,
                                  const Eigen::Vector3f& hull_hi,
                                  const std::function<bool(const Eigen::Vector3f&)>& observed, float voxel = 0.1f,
                                  float truncation = 0.3f) {
  return make_map_where([&boxes](const Eigen::Vector3f& c) { return scene_distance(boxes, c); }, hull_lo, hull_hi,
                        observed, voxel, truncation);
}

inline TsdfMap make_box_map(const std::vector<Box>& boxes, const Eigen::Vector3f& hull_lo,
                            const Eigen::Vector3f& hull_hi, float voxel = 0.1f, float truncation = 0.3f) {
  return make_box_map_where(
      boxes, hull_lo, hull_hi, [](const Eigen::Vector3f&) { return true; }, voxel, truncation);
}

inline TsdfMap make_office_map(float voxel = 0.1f, float truncation = 0.3f) {
  return make_box_map(office_boxes(), Eigen::Vector3f(-0.2f, -0.2f, -0.2f), Eigen::Vector3f(14.2f, 9.2f, 2.8f), voxel,
                      truncation);
}

// Distance along the ray to the first box surface (origin outside every box), or -1.
inline float cast_ray(const std::vector<Box>& boxes, const Eigen::Vector3f& o, const Eigen::Vector3f& dir,
                      float max_range) {
  float best = max_range;
  bool hit = false;
  for (const Box& b : boxes) {
    float t0 = 0.0f, t1 = best;
    bool miss = false;
    for (int a = 0; a < 3 && !miss; ++a) {
      if (std::abs(dir[a]) < 1e-9f) {
        if (o[a] < b.lo[a] || o[a] > b.hi[a]) miss = true;
        continue;
      }
      float ta = (b.lo[a] - o[a]) / dir[a];
      float tb = (b.hi[a] - o[a]) / dir[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      if (t0 > t1) miss = true;
    }
    if (!miss && t0 > 0.0f && t0 < best) {
      best = t0;
      hit = true;
    }
  }
  return hit ? best : -1.0f;
}

// A spinning LiDAR: `rings` beams from -max_elevation to +max_elevation (degrees; 15 like a VLP-16, 45 like an
// OS0), `columns` azimuth steps; points in the sensor frame, with Gaussian range noise.
inline std::vector<Eigen::Vector3f> simulate_scan(const std::vector<Box>& boxes, const Pose& world_T_sensor, Rng& rng,
                                                  int rings = 16, int columns = 180, float range_noise = 0.01f,
                                                  float max_elevation = 15.0f) {
  std::vector<Eigen::Vector3f> points;
  const Eigen::Matrix3f r = world_T_sensor.linear().cast<float>();
  const Eigen::Vector3f o = world_T_sensor.translation().cast<float>();
  for (int ring = 0; ring < rings; ++ring) {
    const float elevation =
        max_elevation * (-1.0f + 2.0f * static_cast<float>(ring) / static_cast<float>(rings - 1)) * 0.017453293f;
    for (int col = 0; col < columns; ++col) {
      const float azimuth = 6.2831853f * static_cast<float>(col) / static_cast<float>(columns);
      const Eigen::Vector3f d_sensor(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                                     std::sin(elevation));
      const float t = cast_ray(boxes, o, r * d_sensor, 30.0f);
      if (t < 0.0f) continue;
      points.push_back(d_sensor * (t + range_noise * static_cast<float>(rng.normal())));
    }
  }
  return points;
}

// A loop through all three rooms at walking pace: `steps` poses 0.4 m apart (following the waypoints), yaw
// along the path, height and tilt wobbling a little (a 6-DoF path, not a planar one).
inline std::vector<Pose> office_trajectory(std::size_t steps) {
  const std::vector<Eigen::Vector2d> waypoints = {
      {2.0, 1.2}, {4.8, 1.0}, {5.2, 3.6}, {8.0, 3.6}, {12.8, 3.5}, {12.8, 4.5}, {9.6, 4.6}, {9.6, 7.5}, {12.5, 8.0},
      {9.6, 7.0}, {9.6, 4.6}, {5.0, 3.6}, {3.0, 5.0}, {3.2, 8.0},  {1.0, 8.0},  {1.0, 3.5}, {2.0, 1.2}};
  std::vector<Pose> poses;
  std::size_t seg = 0;
  double s = 0.0;
  double yaw = 0.0;
  for (std::size_t i = 0; i < steps; ++i) {
    Eigen::Vector2d a = waypoints[seg], b = waypoints[seg + 1];
    while (s > (b - a).norm()) {
      s -= (b - a).norm();
      seg = (seg + 1) % (waypoints.size() - 1);
      a = waypoints[seg];
      b = waypoints[seg + 1];
    }
    const Eigen::Vector2d dir = (b - a).normalized();
    const Eigen::Vector2d p = a + s * dir;
    const double target = std::atan2(dir.y(), dir.x());
    double diff = std::remainder(target - yaw, 2 * M_PI);
    yaw = i == 0 ? target : yaw + std::clamp(diff, -0.6, 0.6);  // turns spread over a few steps
    const double t = static_cast<double>(i);
    poses.push_back(pose_from_xyz_rpy(p.x(), p.y(), 0.9 + 0.05 * std::sin(0.3 * t), 0.03 * std::sin(0.5 * t),
                                      0.03 * std::cos(0.4 * t), yaw));
    s += 0.4;
  }
  return poses;
}

// Odometry: the true relative motions with 3 % + 1 cm translation and 3 % + 0.3° rotation noise per step,
// integrated (drifts like wheel or LiDAR odometry).
inline std::vector<Pose> drifting_odometry(const std::vector<Pose>& truth, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<Pose> odom = {Pose::Identity()};
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const Pose rel = truth[i - 1].inverse() * truth[i];
    const double d = rel.translation().norm();
    const double a = Eigen::AngleAxisd(rel.linear()).angle();
    Pose noisy = rel;
    const double st = 0.03 * d + 0.01;
    const double sr = 0.03 * a + 0.005;
    noisy.translation() += Eigen::Vector3d(st * rng.normal(), st * rng.normal(), 0.3 * st * rng.normal());
    noisy.linear() = noisy.linear() *
                     Eigen::AngleAxisd(sr * rng.normal(), Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                     Eigen::AngleAxisd(0.3 * sr * rng.normal(), Eigen::Vector3d::UnitX()).toRotationMatrix();
    odom.push_back(orthonormalized(odom.back() * noisy));
  }
  return odom;
}

inline double translation_error(const Pose& a, const Pose& b) { return (a.translation() - b.translation()).norm(); }
inline double rotation_error(const Pose& a, const Pose& b) { return rotation_angle_between(a.linear(), b.linear()); }

}  // namespace tsdf_mcl::test
