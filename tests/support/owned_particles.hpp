#pragma once
// Particle arrays backed by a vector, for testing filter parts without an evaluator.
#include <vector>

#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl::test {

struct OwnedParticles {
  std::vector<float> data;
  ParticleArrays view;
  // n particles at the origin with identity rotation.
  explicit OwnedParticles(std::size_t n) : data(8 * n, 0.0f) {
    view = ParticleArrays::over(data.data(), n);
    for (std::size_t i = 0; i < n; ++i) view.qw[i] = 1.0f;
  }
};

}  // namespace tsdf_mcl::test
