#pragma once
// KLD-sampling (Fox 2003): the particle count follows how spread the belief is. Poses are binned into a grid
// over (x, y, z, roll, pitch, yaw); a belief that occupies k bins needs
//   n(k) = (k - 1) / (2 pf_err) * (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) * pf_z)^3
// particles so that, with probability 1 - delta, the KL divergence between the particle approximation and
// the true posterior stays below pf_err. pf_z is the upper standard-normal quantile z_{1-delta} — a number of
// standard deviations, as in nav2, not a probability: 0.99 means 1 - delta = 0.84, 2.33 means 0.99.
//
// nav2 counts bins while it draws samples one at a time, which only works with multinomial draws. Here the
// count is found before resampling, for any resampler: resampling N particles from bin masses m_b is expected
// to populate k(N) = Σ_b min(1, N m_b) bins, and N is the least fixed point of N = n(k(N)) within
// [min_particles, max_particles] (the point where nav2's one-at-a-time loop stops, in expectation).
#include <cstddef>
#include <cstdint>
#include <vector>

#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

struct KldParameters {
  std::size_t min_particles = 500;
  std::size_t max_particles = 100000;
  double pf_err = 0.05;
  double pf_z = 0.99;
  float bin_xy = 0.25f;           // m
  float bin_z = 0.25f;            // m
  float bin_angle = 0.17453292f;  // rad (10°), each of roll, pitch, yaw

  void validate() const;  // throws Error naming the parameter
};

// n(k) above (unclamped); 1 for k <= 1.
double kld_sample_count(double k, double pf_err, double pf_z);

// Keeps its hash table between calls: no allocation once it has grown to the particle count.
class KldSampler {
 public:
  explicit KldSampler(const KldParameters& params);

  // The particle count for the next generation, from particles 0..n-1 and their weights (any positive scale).
  std::size_t required_count(const ParticleArrays& particles, const double* weights, std::size_t n);
  std::size_t occupied_bins() const { return bin_mass_.size(); }  // bins of the last call's weighted set
  const KldParameters& params() const { return params_; }

 private:
  KldParameters params_;
  std::vector<std::uint64_t> keys_;  // open addressing, 0 = empty
  std::vector<std::uint32_t> slot_bin_;
  std::vector<double> bin_mass_;
  std::vector<std::uint64_t> particle_keys_;  // each particle's bin key (scratch)
};

// Bin key of a pose on a grid of the given sizes (positions and roll/pitch/yaw).
std::uint64_t pose_bin_key(const Eigen::Vector3f& position, const Eigen::Quaternionf& rotation, float bin_xy,
                           float bin_z, float bin_angle);

}  // namespace tsdf_mcl
