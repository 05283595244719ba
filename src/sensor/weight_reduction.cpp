#include "tsdf_mcl/sensor/weight_reduction.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace tsdf_mcl {

FitConstants fit_constants(const EndpointModel& model, std::size_t point_count) {
  FitConstants f;
  const double n = static_cast<double>(std::max<std::size_t>(point_count, 1));
  if (model.likelihood == Likelihood::kProduct) {
    f.scale = static_cast<float>(1.0 / (n * model.weight_exponent));
  } else {
    f.scale = static_cast<float>(1.0 / model.weight_exponent);
    f.offset = static_cast<float>(-std::log(n));
  }
  return f;
}

void WeightPartial::add(double log_weight, const double pos[3], const double quat[4], double fit) {
  WeightPartial one;
  one.max_log_weight = log_weight;
  one.weight_sum = 1.0;
  for (int a = 0; a < 3; ++a) one.position[a] = pos[a];
  for (int a = 0; a < 4; ++a) one.quaternion[a] = quat[a];
  one.fit_sum = fit;
  combine(one);
}

void WeightPartial::combine(const WeightPartial& o) {
  fit_sum += o.fit_sum;
  if (o.weight_sum == 0.0) return;
  if (weight_sum == 0.0) {
    const double fit = fit_sum;
    *this = o;
    fit_sum = fit;
    return;
  }
  const double m = std::max(max_log_weight, o.max_log_weight);
  const double sa = std::exp(max_log_weight - m);
  const double sb = std::exp(o.max_log_weight - m);
  weight_sum = weight_sum * sa + o.weight_sum * sb;
  for (int a = 0; a < 3; ++a) position[a] = position[a] * sa + o.position[a] * sb;
  for (int a = 0; a < 4; ++a) quaternion[a] = quaternion[a] * sa + o.quaternion[a] * sb;
  max_log_weight = m;
}

WeightSummary WeightPartial::summary() const {
  WeightSummary s;
  s.max_log_weight = static_cast<float>(max_log_weight);
  s.weight_sum = weight_sum;
  if (weight_sum > 0.0) s.mean_position = Eigen::Vector3d(position[0], position[1], position[2]) / weight_sum;
  s.quaternion_sum = Eigen::Vector4d(quaternion[0], quaternion[1], quaternion[2], quaternion[3]);
  s.fit_sum = fit_sum;
  return s;
}

WeightSummary reduce_weights(const ParticleArrays& p, std::size_t n, const Eigen::Quaternionf& reference,
                             FitConstants fit) {
  constexpr std::size_t kChunk = 4096;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<WeightPartial> partial(chunks);
  const double ref[4] = {reference.w(), reference.x(), reference.y(), reference.z()};
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t c = 0; c < static_cast<std::ptrdiff_t>(chunks); ++c) {
    const std::size_t end = std::min(n, (static_cast<std::size_t>(c) + 1) * kChunk);
    for (std::size_t i = static_cast<std::size_t>(c) * kChunk; i < end; ++i) {
      const double pos[3] = {p.x[i], p.y[i], p.z[i]};
      double q[4] = {p.qw[i], p.qx[i], p.qy[i], p.qz[i]};
      if (q[0] * ref[0] + q[1] * ref[1] + q[2] * ref[2] + q[3] * ref[3] < 0.0) {
        for (double& v : q) v = -v;
      }
      const double l = p.log_weight[i];
      partial[static_cast<std::size_t>(c)].add(l, pos, q, std::exp(l * fit.scale + fit.offset));
    }
  }
  WeightPartial total;
  for (const auto& part : partial) total.combine(part);
  return total.summary();
}

}  // namespace tsdf_mcl
