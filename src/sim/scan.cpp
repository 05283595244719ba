#include <cmath>
#include <vector>

#include "interpolate.hpp"
#include "tsdf_mcl/sim/random.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

namespace {

// A standard normal and a uniform from one 64-bit hash per ray: each ray owns its noise, so the scan does not
// depend on which thread traced which column.
struct RayNoise {
  double normal;
  double uniform;
};

RayNoise ray_noise(std::uint64_t key, std::uint64_t ray) {
  const std::uint64_t a = mix_key(key, 2 * ray);
  const std::uint64_t b = splitmix64(a);
  const double u1 = 1.0 - unit_double(a);
  const double u2 = unit_double(b);
  return {std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2), unit_double(mix_key(key, 2 * ray + 1))};
}

// Replaces `hit` by the nearest walker in front of it, if any (origin o, unit direction d; triangle -1).
// A walker whose cylinder holds the origin is not seen.
void hit_walkers(const std::vector<Walker>& walkers, float f, const Eigen::Vector3f& o, const Eigen::Vector3f& d,
                 RayCaster::Hit& hit) {
  for (const Walker& w : walkers) {
    const Eigen::Vector3f foot = w.start + f * (w.end - w.start);
    const Eigen::Vector2f rel = o.head<2>() - foot.head<2>();
    const float c = rel.squaredNorm() - w.radius * w.radius;
    if (c <= 0.0f && o.z() >= foot.z() && o.z() <= foot.z() + w.height) continue;
    float t = hit.distance;
    Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();
    const float a = d.head<2>().squaredNorm();
    const float b = rel.dot(d.head<2>());
    const float disc = b * b - a * c;
    if (a > 0.0f && c > 0.0f && disc >= 0.0f) {  // the side, entered from outside
      const float side = (-b - std::sqrt(disc)) / a;
      const float z = o.z() + side * d.z();
      if (side > 0.0f && side < t && z >= foot.z() && z <= foot.z() + w.height) {
        t = side;
        normal << (rel + side * d.head<2>()) / w.radius, 0.0f;
      }
    }
    if (d.z() < 0.0f && o.z() > foot.z() + w.height) {  // the head, from above
      const float top = (foot.z() + w.height - o.z()) / d.z();
      if (top < t && (rel + top * d.head<2>()).squaredNorm() <= w.radius * w.radius) {
        t = top;
        normal = Eigen::Vector3f::UnitZ();
      }
    }
    if (t < hit.distance) {
      hit.distance = t;
      hit.normal = normal;
      hit.triangle = -1;
    }
  }
}

}  // namespace

PointCloud simulate_scan(const RayCaster& scene, const LidarModel& lidar, const Pose& sweep_start,
                         const Pose& sweep_end, const ScanNoise& noise, std::uint64_t noise_key,
                         const ScanExtras& extras) {
  std::vector<int>* const hit_triangles = extras.hit_triangles;
  const int columns = lidar.columns;
  const auto beams = lidar.beams();
  const bool moving = !sweep_start.isApprox(sweep_end, 1e-12);
  const Pose end_T_world = sweep_end.inverse();

  std::vector<float> cos_elevation(beams), sin_elevation(beams);
  for (std::size_t b = 0; b < beams; ++b) {
    const double e = lidar.elevations_deg[b] * M_PI / 180.0;
    cos_elevation[b] = static_cast<float>(std::cos(e));
    sin_elevation[b] = static_cast<float>(std::sin(e));
  }

  // x y z intensity per ray, NaN x for no return; compacted in firing order afterwards.
  std::vector<Eigen::Vector4f> returns(lidar.rays());
  std::vector<int> triangles(hit_triangles ? lidar.rays() : 0);
#pragma omp parallel
  {
    std::vector<Eigen::Vector3f> local(beams), world(beams);
    std::vector<RayCaster::Hit> hits(beams);
#pragma omp for schedule(dynamic, 16)
    for (int c = 0; c < columns; ++c) {
      const double azimuth = lidar.azimuth_of(c);
      const auto ca = static_cast<float>(std::cos(azimuth));
      const auto sa = static_cast<float>(std::sin(azimuth));
      const Pose world_T_column = moving ? interpolate(sweep_start, sweep_end, (c + 1.0) / columns) : sweep_end;
      const Eigen::Matrix3f rotation = world_T_column.linear().cast<float>();
      for (std::size_t b = 0; b < beams; ++b) {
        local[b] = Eigen::Vector3f(cos_elevation[b] * ca, cos_elevation[b] * sa, sin_elevation[b]);
        world[b] = rotation * local[b];
      }
      const Eigen::Vector3f origin = world_T_column.translation().cast<float>();
      scene.cast_fan(origin, world.data(), beams, 0.0f, static_cast<float>(lidar.max_range), hits.data());
      if (!extras.walkers.empty()) {
        const auto f = static_cast<float>((c + 1.0) / columns);
        for (std::size_t b = 0; b < beams; ++b) hit_walkers(extras.walkers, f, origin, world[b], hits[b]);
      }
      const Eigen::Isometry3f end_T_column = (end_T_world * world_T_column).cast<float>();
      for (std::size_t b = 0; b < beams; ++b) {
        const std::size_t ray = static_cast<std::size_t>(c) * beams + b;
        Eigen::Vector4f& out = returns[ray];
        out.x() = std::numeric_limits<float>::quiet_NaN();
        if (!hits[b].hit()) continue;
        const RayNoise rn = ray_noise(noise_key, ray);
        if (rn.uniform < noise.dropout) continue;
        const double range = hits[b].distance + noise.range_sigma * rn.normal;
        if (range < lidar.min_range || range > lidar.max_range) continue;
        const Eigen::Vector3f p = local[b] * static_cast<float>(range);
        out.head<3>() = moving ? Eigen::Vector3f(end_T_column * p) : p;
        out.w() = std::abs(hits[b].normal.dot(world[b]));
        if (hit_triangles) triangles[ray] = hits[b].triangle;
      }
    }
  }

  PointCloud cloud;
  cloud.points.reserve(returns.size());
  cloud.intensity.reserve(returns.size());
  if (hit_triangles) hit_triangles->clear();
  if (extras.rings) extras.rings->clear();
  for (std::size_t ray = 0; ray < returns.size(); ++ray) {
    const Eigen::Vector4f& r = returns[ray];
    if (std::isnan(r.x())) continue;
    cloud.points.push_back(r.head<3>());
    cloud.intensity.push_back(r.w());
    if (hit_triangles) hit_triangles->push_back(triangles[ray]);
    if (extras.rings) extras.rings->push_back(static_cast<std::uint16_t>(ray % beams));
  }
  return cloud;
}

}  // namespace tsdf_mcl::sim
