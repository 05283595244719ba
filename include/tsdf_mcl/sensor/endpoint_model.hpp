#pragma once
// The endpoint (likelihood-field) sensor model over a TSDF: a scan point transformed into the map lands at
// signed distance d from the nearest surface; p(point) = z_hit * N(d; 0, sigma_hit) + z_rand / max_range,
// and a point in an unknown cell or outside the map counts as if it lay unknown_distance from a surface (by
// default infinitely far: p_rand = z_rand / max_range only).
#include <cmath>
#include <cstdint>
#include <limits>

#include "tsdf_mcl/map/tsdf_map.hpp"

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
  // Where a point in unknown space (never observed, or outside the map) is taken to lie: this far from a surface.
  // Infinity (the default, as in the reference implementation) makes it a miss, p_rand. The map's truncation
  // treats it like free space beyond the band: a hypothesis a little off, whose far points land just behind
  // a wall (the inside of a wall is unknown in a TSDF), then scores like one whose points land just in front
  // of it instead of like one whose points fly into nowhere; the global search's screening needs that smooth
  // basin (docs/filter.md).
  float unknown_distance = std::numeric_limits<float>::infinity();

  // Throws Error if a parameter is out of range (sigma <= 0, mixture weights negative or both zero, ...).
  void validate() const;

  // Derived constants (in double; tsdf_mcl/sensor/endpoint_kernel.hpp turns them into the float constants that the CPU
  // evaluator and the shaders compute the likelihood from).
  double p_rand() const { return static_cast<double>(z_rand) / max_range; }
  // z_hit / (sigma sqrt(2 pi)): the Gaussian's peak density times its mixture weight.
  double hit_scale() const { return z_hit / (sigma_hit * 2.5066282746310002); }
  // p(point) for a point in unknown space.
  double p_unknown() const {
    if (!std::isfinite(unknown_distance)) return p_rand();
    const double d = unknown_distance;
    return hit_scale() * std::exp(-0.5 * d * d / (static_cast<double>(sigma_hit) * sigma_hit)) + p_rand();
  }
};

}  // namespace tsdf_mcl
