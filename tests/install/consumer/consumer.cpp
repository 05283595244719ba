// Builds a TSDF map of a 6 x 4 x 3 m room from its mesh, tracks a LiDAR standing in it from an initial pose through
// the streaming interface, and checks the estimate: the smallest useful program on the installed library.
// With TSDF_MCL_CONSUMER_CPU_ONLY, it uses the map, sensor, cpu and filter components alone (no Vulkan, Embree,
// Cairo or I/O library needed): it writes the room's distances into the map itself, the CPU evaluator weighs the
// true pose and one 0.3 m off, and the right one must win.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#ifdef TSDF_MCL_CONSUMER_CPU_ONLY
#include "tsdf_mcl/cpu/cpu_evaluator.hpp"
#include "tsdf_mcl/filter/resampling.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"
#else
#include "tsdf_mcl/localizer/localizer.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"
#endif

namespace {

const float x = 6.0f, y = 4.0f, z = 3.0f;  // the room's size

#ifdef TSDF_MCL_CONSUMER_CPU_ONLY
// The room's signed distances (positive inside) within the truncation band of its walls, voxel by voxel.
tsdf_mcl::TsdfMap room_map() {
  tsdf_mcl::TsdfMap map =
      tsdf_mcl::TsdfMap::covering(0.1f, 0.3f, {-0.5f, -0.5f, -0.5f}, {x + 0.5f, y + 0.5f, z + 0.5f});
  const Eigen::Vector3i first = map.voxel_of({-0.3f, -0.3f, -0.3f}),
                        last = map.voxel_of({x + 0.3f, y + 0.3f, z + 0.3f});
  for (int i = first.x(); i <= last.x(); ++i)
    for (int j = first.y(); j <= last.y(); ++j)
      for (int k = first.z(); k <= last.z(); ++k) {
        const Eigen::Vector3f c = map.center_of({i, j, k});
        const float d = std::min({c.x(), x - c.x(), c.y(), y - c.y(), c.z(), z - c.z()});
        if (std::abs(d) <= map.truncation()) map.set_distance({i, j, k}, d);
      }
  return map;
}
#else
tsdf_mcl::TsdfMap room_map() {
  // The room's inside faces, normals pointing into the room (the free side).
  tsdf_mcl::TriangleMesh room;
  room.vertices = {{0, 0, 0}, {x, 0, 0}, {x, y, 0}, {0, y, 0}, {0, 0, z}, {x, 0, z}, {x, y, z}, {0, y, z}};
  room.triangles = {{0, 1, 2}, {0, 2, 3}, {4, 6, 5}, {4, 7, 6}, {0, 4, 5}, {0, 5, 1},
                    {1, 5, 6}, {1, 6, 2}, {2, 6, 7}, {2, 7, 3}, {3, 7, 4}, {3, 4, 0}};
  tsdf_mcl::MeshMapOptions map_options;
  map_options.voxel_size = 0.1f;
  return tsdf_mcl::build_map_from_mesh(room, map_options);
}
#endif

}  // namespace

int main() {
  const tsdf_mcl::TsdfMap map = room_map();

  // A scan from (2, 1.5, 1): where rays in every direction meet the walls.
  const Eigen::Vector3f sensor(2.0f, 1.5f, 1.0f);
  std::vector<Eigen::Vector3f> scan;
  for (int i = 0; i < 64; ++i) {
    for (int j = -6; j <= 6; ++j) {
      const float a = 2.0f * static_cast<float>(M_PI) * static_cast<float>(i) / 64.0f,
                  e = 0.12f * static_cast<float>(j);
      const Eigen::Vector3f d(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
      float t = 1e9f;  // distance to the first wall along d
      for (int k = 0; k < 3; ++k) {
        if (std::abs(d[k]) < 1e-6f) continue;
        const float wall = d[k] > 0 ? Eigen::Vector3f(x, y, z)[k] : 0.0f;
        t = std::min(t, (wall - sensor[k]) / d[k]);
      }
      scan.push_back(t * d);  // sensor frame: the sensor is not rotated
    }
  }

#ifdef TSDF_MCL_CONSUMER_CPU_ONLY
  tsdf_mcl::CpuEvaluator evaluator(map, 1);
  evaluator.reserve(2, scan.size());
  const tsdf_mcl::ParticleArrays particles = evaluator.particles();
  particles.set(0, sensor, Eigen::Quaternionf::Identity());
  particles.set(1, sensor + Eigen::Vector3f(0.3f, 0.0f, 0.0f), Eigen::Quaternionf::Identity());
  evaluator.set_points(scan);
  evaluator.evaluate(2, tsdf_mcl::EndpointModel(), Eigen::Quaternionf::Identity());
  const double weights[2] = {1.0, std::exp(static_cast<double>(particles.log_weight[1] - particles.log_weight[0]))};
  std::printf("consumer (map, sensor, cpu, filter): log-weights %.2f (true pose), %.2f (0.3 m off); ESS %.3f\n",
              particles.log_weight[0], particles.log_weight[1], tsdf_mcl::effective_sample_size(weights, 2));
  return particles.log_weight[0] > particles.log_weight[1] ? 0 : 1;
#else
  tsdf_mcl::LocalizerOptions options;
  options.evaluator.backend = tsdf_mcl::Backend::kCpu;
  options.filter.initial_particles = 2000;
  options.initial_pose = tsdf_mcl::pose_from_xyz_rpy(2.2, 1.4, 1.0, 0.0, 0.0, 0.05);
  tsdf_mcl::Localizer localizer(map, options);
  tsdf_mcl::Pose odom = tsdf_mcl::Pose::Identity();
  for (int k = 0; k < 5; ++k) localizer.process(0.1 * k, scan, odom);
  const Eigen::Vector3d error = localizer.estimate().pose.translation() - sensor.cast<double>();
  std::printf("consumer: estimate %.3f %.3f %.3f, error %.3f m\n", localizer.estimate().pose.translation().x(),
              localizer.estimate().pose.translation().y(), localizer.estimate().pose.translation().z(), error.norm());
  return error.norm() < 0.2 ? 0 : 1;
#endif
}
