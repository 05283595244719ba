#pragma once
// The reduction over particles (max log-weight, Σw, Σw·position, Σw·quaternion, fit), CPU definition of
// shaders/reduce.comp.
#include <cstddef>

#include "tsdf_mcl/sensor/endpoint_model.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

// fit_i = exp(log_weight_i * scale + offset) is particle i's per-point mean likelihood.
struct FitConstants {
  float scale = 1.0f;
  float offset = 0.0f;
};
FitConstants fit_constants(const EndpointModel& model, std::size_t point_count);

// Partial result of a block of particles, combined like an online softmax: sums are kept relative to the
// block's own maximum, so combining rescales the smaller side by exp(m_small - m_large) and nothing overflows.
struct WeightPartial {
  double max_log_weight = -1e300;
  double weight_sum = 0.0;
  double position[3] = {0, 0, 0};
  double quaternion[4] = {0, 0, 0, 0};  // w x y z
  double fit_sum = 0.0;

  void add(double log_weight, const double pos[3], const double quat[4], double fit);
  void combine(const WeightPartial& other);
  WeightSummary summary() const;
};

// Reduces particles 0..n-1 in double (threads over fixed chunks, so the result is thread-count independent).
WeightSummary reduce_weights(const ParticleArrays& particles, std::size_t n,
                             const Eigen::Quaternionf& reference_rotation, FitConstants fit);

}  // namespace tsdf_mcl
