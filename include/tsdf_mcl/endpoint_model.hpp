#pragma once
// The endpoint (likelihood-field) sensor model over a TSDF: a scan point transformed into the map lands at
// signed distance d from the nearest surface; p(point) = z_hit * N(d; 0, sigma_hit) + z_rand / max_range,
// and a point in an unknown cell or outside the map counts as p_rand = z_rand / max_range only.
#include <cmath>
#include <cstdint>

#include "tsdf_mcl/tsdf_map.hpp"

namespace tsdf_mcl {

enum class Likelihood : std::uint32_t {
  kProduct = 0,  // log w = Σ log p(point): the proper joint likelihood, in the log domain (no underflow)
  kSum = 1,      // log w = log Σ p(point): the reference implementation's summed form, for comparison
};
enum class Interpolation : std::uint32_t { kNearest = 0, kTrilinear = 1 };

struct EndpointModel {
  float sigma_hit = 0.1f;  // m
  float z_hit = 0.9f;
  float z_rand = 0.1f;
  float max_range = 60.0f;  // m: p_rand = z_rand / max_range
  Likelihood likelihood = Likelihood::kProduct;
  Interpolation interpolation = Interpolation::kNearest;
  // The particle's log-weight is multiplied by this. Scan points are not independent (neighbouring beams see
  // the same surface), so the plain joint likelihood of 1000 points is far too confident; an exponent < 1
  // tempers it. 1 = the textbook product.
  float weight_exponent = 1.0f;

  // Throws Error if a parameter is out of range (sigma <= 0, mixture weights negative or both zero, ...).
  void validate() const;

  double p_rand() const { return static_cast<double>(z_rand) / max_range; }
  // z_hit / (sigma sqrt(2 pi)): the Gaussian's peak density times its mixture weight.
  double hit_scale() const { return z_hit / (sigma_hit * 2.5066282746310002); }
  // p(point) given the map sample at its end. This is the CPU definition the shader mirrors.
  double point_likelihood(const TsdfMap::Sample& sample) const {
    if (!sample.known) return p_rand();
    const double d = sample.distance;
    return hit_scale() * std::exp(-0.5 * d * d / (static_cast<double>(sigma_hit) * sigma_hit)) + p_rand();
  }
};

}  // namespace tsdf_mcl
