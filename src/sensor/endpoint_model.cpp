#include "tsdf_mcl/sensor/endpoint_model.hpp"

#include <string>

#include "tsdf_mcl/sensor/endpoint_kernel.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

Backend parse_backend(const std::string& name) {
  if (name == "auto") return Backend::kAuto;
  if (name == "vulkan") return Backend::kVulkan;
  if (name == "cpu") return Backend::kCpu;
  throw Error("unknown backend '" + name + "' (auto, vulkan or cpu)");
}

WeightLayout parse_weight_layout(const std::string& name) {
  if (name == "auto") return WeightLayout::kAuto;
  if (name == "invocation") return WeightLayout::kInvocationPerParticle;
  if (name == "subgroup") return WeightLayout::kSubgroupPerParticle;
  throw Error("unknown weight_layout '" + name + "' (auto, invocation or subgroup)");
}

void EndpointModel::validate() const {
  auto bad = [](const std::string& what) { throw Error("sensor model: " + what); };
  if (!(sigma_hit > 0.0f) || !std::isfinite(sigma_hit)) bad("sigma_hit must be positive");
  if (!(z_hit >= 0.0f) || !std::isfinite(z_hit)) bad("z_hit must not be negative");
  // p_rand > 0 keeps every log-likelihood finite, even for points in unknown space.
  if (!(z_rand > 0.0f) || !std::isfinite(z_rand)) bad("z_rand must be positive");
  if (!(max_range > 0.0f) || !std::isfinite(max_range)) bad("max_range must be positive");
  if (!(weight_exponent > 0.0f) || !std::isfinite(weight_exponent)) bad("weight_exponent must be positive");
  if (!(unknown_distance >= 0.0f)) bad("unknown_distance must not be negative");
  if (likelihood != Likelihood::kProduct && likelihood != Likelihood::kSum) bad("unknown likelihood form");
  if (interpolation != Interpolation::kNearest && interpolation != Interpolation::kTrilinear) {
    bad("unknown interpolation");
  }
}

namespace {

// The model's probability of each point at one pose, in point order.
template <typename Visit>
void visit_point_likelihoods(const TsdfMap& map, const EndpointModel& model, const Eigen::Vector3f& position,
                             const Eigen::Quaternionf& rotation, const std::vector<Eigen::Vector3f>& points,
                             Visit&& visit) {
  const kernel::MapView view(map);
  const kernel::ModelConstants k(model);
  float r[9];
  kernel::rotation_matrix(rotation.w(), rotation.x(), rotation.y(), rotation.z(), r);
  const float t[3] = {position.x(), position.y(), position.z()};
  for (const Eigen::Vector3f& pt : points) {
    float g[3];
    kernel::to_grid(r, t, view.inv_voxel, pt.x(), pt.y(), pt.z(), g);
    if (model.interpolation == Interpolation::kNearest) {
      const std::int32_t q = kernel::sample_nearest(view, g);
      visit(static_cast<double>(q == TsdfMap::kUnknownValue ? k.p_unknown
                                                            : k.likelihood(static_cast<float>(q) * view.quant_step)));
    } else {
      float d = 0.0f;
      visit(static_cast<double>(kernel::sample_trilinear(view, g, &d) ? k.likelihood(d) : k.p_unknown));
    }
  }
}

}  // namespace

double reference_log_weight(const TsdfMap& map, const EndpointModel& model, const Eigen::Vector3f& position,
                            const Eigen::Quaternionf& rotation, const std::vector<Eigen::Vector3f>& points) {
  double log_sum = 0.0;
  double sum = 0.0;
  visit_point_likelihoods(map, model, position, rotation, points, [&](double p) {
    log_sum += std::log(p);
    sum += p;
  });
  return model.weight_exponent * (model.likelihood == Likelihood::kProduct ? log_sum : std::log(sum));
}

void point_log_likelihoods(const TsdfMap& map, const EndpointModel& model, const Eigen::Vector3f& position,
                           const Eigen::Quaternionf& rotation, const std::vector<Eigen::Vector3f>& points,
                           std::vector<double>& out) {
  out.clear();
  out.reserve(points.size());
  visit_point_likelihoods(map, model, position, rotation, points, [&](double p) { out.push_back(std::log(p)); });
}

}  // namespace tsdf_mcl
