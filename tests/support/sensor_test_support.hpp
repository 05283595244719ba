#pragma once
// Shared fixtures for sensor-update tests: an analytic TSDF scene and random particles / scans.
#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/backends/make_evaluator.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::test {

// The Vulkan backend with the validation layers on: every validation message fails the test.
inline EvaluatorOptions vulkan_options() {
  EvaluatorOptions o;
  o.backend = Backend::kVulkan;
  o.validation = true;
  o.on_validation_message = [](const std::string& m) { ADD_FAILURE() << "Vulkan validation: " << m; };
  return o;
}

// A Vulkan evaluator, or a test failure (and null) where no device works.
inline std::unique_ptr<SensorEvaluator> make_vulkan(const TsdfMap& map,
                                                    const EvaluatorOptions& options = vulkan_options()) {
  try {
    return make_evaluator(map, options);
  } catch (const Error& e) {
    ADD_FAILURE() << "no Vulkan device (tests need lavapipe: mesa-vulkan-drivers): " << e.what();
    return nullptr;
  }
}

// A 6 x 4 x 3 m box room (inside positive) with a pillar, exact signed distances in the truncation band and
// free blocks in the middle; some blocks left unknown so lookups hit all three kinds of coarse entries.
inline TsdfMap make_room_map(float voxel = 0.1f, float truncation = 0.3f) {
  TsdfMap map =
      TsdfMap::covering(voxel, truncation, Eigen::Vector3f(-3.5f, -2.5f, -0.5f), Eigen::Vector3f(3.5f, 2.5f, 3.5f));
  auto sdf = [](const Eigen::Vector3f& p) {
    const float room = std::min({p.x() + 3.0f, 3.0f - p.x(), p.y() + 2.0f, 2.0f - p.y(), p.z(), 3.0f - p.z()});
    const Eigen::Vector2f c(1.0f, 0.5f);
    const float pillar = (Eigen::Vector2f(p.x(), p.y()) - c).norm() - 0.3f;
    return std::min(room, pillar);
  };
  const Eigen::Vector3i lo = map.min_block() * TsdfMap::kBlockSize;
  const Eigen::Vector3i hi = (map.min_block() + map.dims_blocks()) * TsdfMap::kBlockSize;
  for (int z = lo.z(); z < hi.z(); ++z)
    for (int y = lo.y(); y < hi.y(); ++y)
      for (int x = lo.x(); x < hi.x(); ++x) {
        const Eigen::Vector3i v(x, y, z);
        const float d = sdf(map.center_of(v));
        if (d < -truncation) continue;                   // deep inside walls: unknown
        if (x < lo.x() + 4 && y < lo.y() + 4) continue;  // a corner never observed
        map.set_distance(v, d);
      }
  map.compact();
  return map;
}

inline void random_particles(const ParticleArrays& p, std::size_t n, std::mt19937& rng, const Eigen::Vector3f& lo,
                             const Eigen::Vector3f& hi) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3f pos = lo + (hi - lo).cwiseProduct(Eigen::Vector3f(u(rng), u(rng), u(rng)));
    const Eigen::Quaternionf q = Eigen::Quaternionf::UnitRandom();
    p.set(i, pos, q);
  }
}

inline std::vector<Eigen::Vector3f> random_scan(std::size_t n, std::mt19937& rng, float max_range = 4.0f) {
  std::normal_distribution<float> g(0.0f, 1.0f);
  std::uniform_real_distribution<float> r(0.3f, max_range);
  std::vector<Eigen::Vector3f> pts(n);
  for (auto& p : pts) p = Eigen::Vector3f(g(rng), g(rng), 0.3f * g(rng)).normalized() * r(rng);
  return pts;
}

}  // namespace tsdf_mcl::test
