#include "tsdf_mcl/endpoint_model.hpp"

#include <string>

#include "cpu/endpoint_kernel.hpp"
#include "tsdf_mcl/error.hpp"
#include "tsdf_mcl/sensor_evaluator.hpp"

namespace tsdf_mcl {

void EndpointModel::validate() const {
  auto bad = [](const std::string& what) { throw Error("sensor model: " + what); };
  if (!(sigma_hit > 0.0f) || !std::isfinite(sigma_hit)) bad("sigma_hit must be positive");
  if (!(z_hit >= 0.0f) || !std::isfinite(z_hit)) bad("z_hit must not be negative");
  // p_rand > 0 keeps every log-likelihood finite, even for points in unknown space.
  if (!(z_rand > 0.0f) || !std::isfinite(z_rand)) bad("z_rand must be positive");
  if (!(max_range > 0.0f) || !std::isfinite(max_range)) bad("max_range must be positive");
  if (!(weight_exponent > 0.0f) || !std::isfinite(weight_exponent)) bad("weight_exponent must be positive");
  if (likelihood != Likelihood::kProduct && likelihood != Likelihood::kSum) bad("unknown likelihood form");
  if (interpolation != Interpolation::kNearest && interpolation != Interpolation::kTrilinear) {
    bad("unknown interpolation");
  }
}

double reference_log_weight(const TsdfMap& map, const EndpointModel& model, const Eigen::Vector3f& position,
                            const Eigen::Quaternionf& rotation, const std::vector<Eigen::Vector3f>& points) {
  const kernel::MapView view(map);
  float r[9];
  kernel::rotation_matrix(rotation.w(), rotation.x(), rotation.y(), rotation.z(), r);
  const float t[3] = {position.x(), position.y(), position.z()};
  double log_sum = 0.0;
  double sum = 0.0;
  for (const Eigen::Vector3f& pt : points) {
    float g[3];
    kernel::to_grid(r, t, view.inv_voxel, pt.x(), pt.y(), pt.z(), g);
    TsdfMap::Sample s;
    if (model.interpolation == Interpolation::kNearest) {
      const std::int32_t q = kernel::sample_nearest(view, g);
      s.known = q != TsdfMap::kUnknownValue;
      s.distance = static_cast<float>(q) * view.quant_step;
    } else {
      s.known = kernel::sample_trilinear(view, g, &s.distance);
    }
    const double p = model.point_likelihood(s);
    log_sum += std::log(p);
    sum += p;
  }
  return model.weight_exponent * (model.likelihood == Likelihood::kProduct ? log_sum : std::log(sum));
}

}  // namespace tsdf_mcl
