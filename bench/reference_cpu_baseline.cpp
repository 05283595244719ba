#include "reference_cpu_baseline.hpp"

#include <cmath>

namespace tsdf_mcl::bench {

void reference_cpu_weights(const TsdfMap& map, const EndpointModel& model, const ParticleArrays& p, std::size_t n,
                           const std::vector<Eigen::Vector3f>& points) {
  const float inv_2s2 = 0.5f / (model.sigma_hit * model.sigma_hit);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    Eigen::Matrix4f transform = Eigen::Matrix4f::Identity();
    transform.block<3, 3>(0, 0) = p.rotation(static_cast<std::size_t>(i)).toRotationMatrix();
    transform.block<3, 1>(0, 3) = p.position(static_cast<std::size_t>(i));
    float sum = 0.0f;
    for (const Eigen::Vector3f& point : points) {
      const Eigen::Vector4f world = transform * point.homogeneous();
      const TsdfMap::Sample s = map.nearest(world.head<3>());
      if (s.known) sum += std::exp(-s.distance * s.distance * inv_2s2);
    }
    p.log_weight[i] = std::log(sum + 1e-30f);
  }
}

}  // namespace tsdf_mcl::bench
