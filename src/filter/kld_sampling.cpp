#include "tsdf_mcl/filter/kld_sampling.hpp"

#include <algorithm>
#include <cmath>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"
#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/core/random.hpp"

namespace tsdf_mcl {

void KldParameters::validate() const {
  if (min_particles == 0) throw Error("min_particles must be at least 1");
  if (max_particles < min_particles) throw Error("max_particles must not be below min_particles");
  if (max_particles > 0xFFFFFFFFull) throw Error("max_particles must fit in 32 bits");
  if (!(pf_err > 0.0 && pf_err < 1.0)) throw Error("pf_err must lie in (0, 1)");
  if (!(pf_z > -5.0 && pf_z < 10.0)) throw Error("pf_z must be a standard-normal quantile (e.g. 0.99 or 2.33)");
  for (const auto& [name, v] :
       {std::pair{"kld_bin_xy", bin_xy}, std::pair{"kld_bin_z", bin_z}, std::pair{"kld_bin_angle", bin_angle}}) {
    if (!(v > 0.0f) || !std::isfinite(v)) throw Error(std::string(name) + " must be positive");
  }
}

double kld_sample_count(double k, double pf_err, double pf_z) {
  if (k <= 1.0) return 1.0;
  const double a = 2.0 / (9.0 * (k - 1.0));
  const double b = 1.0 - a + std::sqrt(a) * pf_z;
  return (k - 1.0) / (2.0 * pf_err) * b * b * b;
}

std::uint64_t pose_bin_key(const Eigen::Vector3f& p, const Eigen::Quaternionf& q, float bin_xy, float bin_z,
                           float bin_angle) {
  const Eigen::Vector3d rpy = rpy_of(q.cast<double>().toRotationMatrix());
  const std::int64_t cell[6] = {static_cast<std::int64_t>(std::floor(p.x() / bin_xy)),
                                static_cast<std::int64_t>(std::floor(p.y() / bin_xy)),
                                static_cast<std::int64_t>(std::floor(p.z() / bin_z)),
                                static_cast<std::int64_t>(std::floor(rpy.x() / bin_angle)),
                                static_cast<std::int64_t>(std::floor(rpy.y() / bin_angle)),
                                static_cast<std::int64_t>(std::floor(rpy.z() / bin_angle))};
  std::uint64_t key = 0x2545F4914F6CDD1Dull;
  for (std::int64_t c : cell) key = hash_combine(key, static_cast<std::uint64_t>(c));
  return key | 1u;  // never 0, the empty-slot marker
}

KldSampler::KldSampler(const KldParameters& params) : params_(params) { params_.validate(); }

std::size_t KldSampler::required_count(const ParticleArrays& particles, const double* weights, std::size_t n) {
  std::size_t slots = 16;
  while (slots < 2 * n) slots *= 2;
  if (keys_.size() < slots) {
    keys_.resize(slots);
    slot_bin_.resize(slots);
  }
  slots = keys_.size();
  std::fill(keys_.begin(), keys_.end(), 0u);
  bin_mass_.clear();
  double total = 0.0;
  // The bins' keys (Euler angles a particle) in parallel; the table in particle order, sequential, so the bins'
  // numbering and sums do not depend on the threads.
  particle_keys_.resize(n);
#pragma omp parallel for schedule(static) if (n >= kParallelParticles)
  for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(n); ++k) {
    const auto i = static_cast<std::size_t>(k);
    particle_keys_[i] =
        pose_bin_key(particles.position(i), particles.rotation(i), params_.bin_xy, params_.bin_z, params_.bin_angle);
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!(weights[i] > 0.0)) continue;
    const std::uint64_t key = particle_keys_[i];
    std::size_t s = static_cast<std::size_t>(key) & (slots - 1);
    while (keys_[s] != 0 && keys_[s] != key) s = (s + 1) & (slots - 1);
    if (keys_[s] == 0) {
      keys_[s] = key;
      slot_bin_[s] = static_cast<std::uint32_t>(bin_mass_.size());
      bin_mass_.push_back(0.0);
    }
    bin_mass_[slot_bin_[s]] += weights[i];
    total += weights[i];
  }
  if (!(total > 0.0)) throw Error("KLD-sampling: the weights do not sum to a positive number");
  const double lo = static_cast<double>(params_.min_particles);
  const double hi = static_cast<double>(params_.max_particles);
  // k(N) and n(k) are non-decreasing, so iterating from min_particles climbs to the least fixed point.
  double count = lo;
  for (int iteration = 0; iteration < 100; ++iteration) {
    double k = 0.0;
    for (double m : bin_mass_) k += std::min(1.0, count * m / total);
    const double next = std::clamp(std::ceil(kld_sample_count(k, params_.pf_err, params_.pf_z)), lo, hi);
    if (next <= count) break;
    count = next;
  }
  return static_cast<std::size_t>(count);
}

}  // namespace tsdf_mcl
