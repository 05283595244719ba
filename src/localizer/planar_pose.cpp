#include "tsdf_mcl/localizer/planar_pose.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <limits>

#include "tsdf_mcl/filter/scan_gravity.hpp"

namespace tsdf_mcl {

std::vector<double> floors_under(const TsdfMap& map, double x, double y) {
  std::vector<double> floors;
  if (map.empty()) return floors;
  const Eigen::Vector3f lo = map.world_min(), hi = map.world_max();
  if (x < lo.x() || x > hi.x() || y < lo.y() || y > hi.y()) return floors;
  const Eigen::Vector3i top = map.voxel_of(Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), hi.z()));
  const Eigen::Vector3i bottom = map.voxel_of(Eigen::Vector3f(static_cast<float>(x), static_cast<float>(y), lo.z()));
  std::optional<float> below;  // distance of the voxel under the current one
  for (Eigen::Vector3i v = bottom; v.z() <= top.z(); ++v.z()) {
    const std::optional<float> d = map.distance(v);
    if (below && d && *below <= 0.0f && *d > 0.0f) {
      const double t = static_cast<double>(*below) / static_cast<double>(*below - *d);  // zero crossing in [0, 1)
      floors.push_back(static_cast<double>(map.center_of(v).z()) - map.voxel_size() * (1.0 - t));
    }
    below = d;
  }
  return floors;
}

std::optional<Pose> pose_from_planar(const TsdfMap& map, double x, double y, double yaw,
                                     const std::vector<Eigen::Vector3f>& scan, const Pose& base_T_sensor,
                                     std::optional<double> z_hint) {
  // The scan's up candidates are directions in the sensor frame; the base's +z tells up from down.
  const GravityEstimate gravity = estimate_gravity(scan);
  const GravityCandidate* best = nullptr;
  Eigen::Vector3d up_base = Eigen::Vector3d::UnitZ();
  for (const GravityCandidate& c : gravity.candidates) {
    const Eigen::Vector3d u = base_T_sensor.rotation() * c.up.cast<double>();
    if (c.has_height && (!best || u.z() > up_base.z())) {
      best = &c;
      up_base = u;
    }
  }
  if (!best) return std::nullopt;
  const std::vector<double> floors = floors_under(map, x, y);
  if (floors.empty()) return std::nullopt;
  // The base's height above the floor: the sensor's, less the sensor's height above the base along up.
  const double height = static_cast<double>(best->height) - up_base.dot(base_T_sensor.translation());
  double z = floors.front() + height;
  if (z_hint) {
    double nearest = std::numeric_limits<double>::infinity();
    for (double f : floors) {
      if (std::abs(f + height - *z_hint) < nearest) {
        nearest = std::abs(f + height - *z_hint);
        z = f + height;
      }
    }
  }
  // world_R_base takes up (in the base frame) to the world's +z, then turns by yaw about it.
  const Eigen::Quaterniond tilt = Eigen::Quaterniond::FromTwoVectors(up_base, Eigen::Vector3d::UnitZ());
  Pose pose = Pose::Identity();
  pose.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * tilt).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(x, y, z);
  return pose;
}

}  // namespace tsdf_mcl
