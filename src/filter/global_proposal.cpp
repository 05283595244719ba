#include "tsdf_mcl/filter/global_proposal.hpp"

#include <algorithm>
#include <cmath>

#include "tsdf_mcl/sensor/endpoint_kernel.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"

namespace tsdf_mcl {
namespace {
constexpr double kPi = 3.141592653589793;
constexpr int B = TsdfMap::kBlockSize;
}  // namespace

void ProposalOptions::validate() const {
  if (!(uniform_share >= 0.0 && uniform_share <= 1.0)) throw Error("init_uniform_share must lie in [0, 1]");
  if (!(min_angle_std >= 0.0) || !std::isfinite(min_angle_std))
    throw Error("proposal: min_angle_std must not be negative");
  if (!(min_height_std >= 0.0) || !std::isfinite(min_height_std))
    throw Error("proposal: min_height_std must not be negative");
  if (!(heading_std >= 0.0) || !std::isfinite(heading_std)) throw Error("proposal: heading_std must not be negative");
  if (!(uniform_heading_share >= 0.0 && uniform_heading_share <= 1.0))
    throw Error("proposal: uniform_heading_share must lie in [0, 1]");
  gravity.validate();
}

std::vector<Eigen::Vector3f> map_surface_normals(const TsdfMap& map) {
  const kernel::MapView view(map);
  const Eigen::Vector3i dims = map.dims_blocks();
  const std::vector<std::uint32_t>& coarse = map.coarse_index();
  // Surface voxels of at most ~4000 blocks spread over the map: plenty for directions, bounded cost.
  std::size_t allocated = 0;
  for (std::uint32_t e : coarse) allocated += e < TsdfMap::kFreeBlock ? 1 : 0;
  const std::size_t every = std::max<std::size_t>(1, allocated / 4000);
  const float near = 1.5f * map.voxel_size() / map.quantization_step();  // |q| of voxels at the surface
  std::vector<Eigen::Vector3f> normals;
  std::size_t seen = 0;
  for (std::size_t c = 0; c < coarse.size(); ++c) {
    if (coarse[c] >= TsdfMap::kFreeBlock || seen++ % every != 0) continue;
    const auto cc = static_cast<int>(c);
    const Eigen::Vector3i block =
        map.min_block() + Eigen::Vector3i(cc % dims.x(), (cc / dims.x()) % dims.y(), cc / (dims.x() * dims.y()));
    for (int l = 0; l < TsdfMap::kVoxelsPerBlock; ++l) {
      const Eigen::Vector3i v = block * B + Eigen::Vector3i(l % B, (l / B) % B, l / (B * B));
      const std::int32_t q = view.fetch(v.x(), v.y(), v.z());
      if (q == TsdfMap::kUnknownValue || std::abs(static_cast<float>(q)) > near) continue;
      Eigen::Vector3f g;
      bool known = true;
      for (int a = 0; a < 3 && known; ++a) {
        Eigen::Vector3i lo = v, hi = v;
        lo[a] -= 1;
        hi[a] += 1;
        const std::int32_t ql = view.fetch(lo.x(), lo.y(), lo.z());
        const std::int32_t qh = view.fetch(hi.x(), hi.y(), hi.z());
        known = ql != TsdfMap::kUnknownValue && qh != TsdfMap::kUnknownValue;
        g[a] = static_cast<float>(qh - ql);
      }
      if (known && g.norm() > 0.0f) normals.push_back(g.normalized());
    }
  }
  return normals;
}

Eigen::Vector3f map_up_axis(const TsdfMap& map) {
  return refine_up_axis(map_surface_normals(map), Eigen::Vector3f::UnitZ());
}

namespace {

// Azimuths of the wall normals (those within 10° of horizontal) about `up`, measured from `e1` towards
// up x e1: a histogram of 1° bins, smoothed over +-3°.
std::vector<double> wall_azimuths(const std::vector<Eigen::Vector3f>& normals, const Eigen::Quaterniond& to_map,
                                  const Eigen::Vector3d& up, const Eigen::Vector3d& e1) {
  std::vector<double> h(360, 0.0);
  const Eigen::Vector3d e2 = up.cross(e1);
  const double horizontal = std::sin(10.0 * kPi / 180.0);
  for (const Eigen::Vector3f& nf : normals) {
    const Eigen::Vector3d n = to_map * nf.cast<double>();
    if (std::abs(n.dot(up)) > horizontal) continue;
    double az = std::atan2(n.dot(e2), n.dot(e1)) * 180.0 / kPi;
    if (az < 0.0) az += 360.0;
    h[static_cast<std::size_t>(az) % 360] += 1.0;
  }
  std::vector<double> smooth(360, 0.0);
  for (int b = 0; b < 360; ++b) {
    for (int d = -3; d <= 3; ++d)
      smooth[static_cast<std::size_t>((b + d + 360) % 360)] += h[static_cast<std::size_t>(b)] * (4 - std::abs(d));
  }
  return smooth;
}

}  // namespace

GlobalProposal::GlobalProposal(const TsdfMap& map, const GlobalInitOptions& init, const ProposalOptions& options)
    : init_(init), options_(options), free_space_(map, init) {
  options_.validate();
  const std::vector<Eigen::Vector3f> normals = map_surface_normals(map);
  map_up_ = refine_up_axis(normals, Eigen::Vector3f::UnitZ());
  map_walls_ = wall_azimuths(normals, Eigen::Quaterniond::Identity(), map_up_.cast<double>(),
                             map_up_.cast<double>().unitOrthogonal());
}

const std::vector<GravityCandidate>& GlobalProposal::use_scan(const std::vector<Eigen::Vector3f>& scan,
                                                              const std::optional<Eigen::Vector3f>& imu_up) {
  const GravityEstimate estimate = estimate_gravity(scan, options_.gravity, imu_up);
  candidates_ = estimate.candidates;
  if (init_.max_tilt < kPi) {
    // Gravity known to the user: keep what agrees with it (the sensor's z axis within max_tilt of up).
    const auto cos_max = static_cast<float>(std::cos(std::min(init_.max_tilt, kPi)));
    candidates_.erase(std::remove_if(candidates_.begin(), candidates_.end(),
                                     [&](const GravityCandidate& c) { return c.up.z() < cos_max; }),
                      candidates_.end());
  }
  headings_.clear();
  for (const GravityCandidate& c : candidates_) headings_.push_back(headings_for(c, estimate.normals));
  return candidates_;
}

std::vector<float> GlobalProposal::headings_for(const GravityCandidate& c,
                                                const std::vector<Eigen::Vector3f>& normals) const {
  // The yaws that turn the scan's walls onto the map's: peaks of the circular cross-correlation of the two
  // azimuth histograms (a building of right angles gives four).
  const Eigen::Vector3d up = map_up_.cast<double>();
  const std::vector<double> scan =
      wall_azimuths(normals, Eigen::Quaterniond::FromTwoVectors(c.up.cast<double>(), up), up, up.unitOrthogonal());
  double walls = 0.0;
  for (double v : scan) walls += v;
  if (walls < 16.0 * 10.0) return {};  // fewer than ~10 wall patches: no heading to trust
  std::vector<double> correlation(360, 0.0);
  for (int shift = 0; shift < 360; ++shift) {
    for (int b = 0; b < 360; ++b) {
      correlation[static_cast<std::size_t>(shift)] +=
          scan[static_cast<std::size_t>(b)] * map_walls_[static_cast<std::size_t>((b + shift) % 360)];
    }
  }
  std::vector<float> peaks;
  const double top = *std::max_element(correlation.begin(), correlation.end());
  while (peaks.size() < 8) {
    const auto best = static_cast<int>(std::max_element(correlation.begin(), correlation.end()) - correlation.begin());
    if (!(correlation[static_cast<std::size_t>(best)] > 0.25 * top)) break;
    peaks.push_back(static_cast<float>(best * kPi / 180.0));
    for (int d = -15; d <= 15; ++d) correlation[static_cast<std::size_t>((best + d + 360) % 360)] = 0.0;
  }
  return peaks;
}

Eigen::Quaternionf GlobalProposal::rotation_for(std::size_t k, Rng& rng) const {
  const GravityCandidate& c = candidates_[k];
  const std::vector<float>& headings = headings_[k];
  const Eigen::Vector3d up = map_up_.cast<double>();
  // The sensor's up onto the map's, a turn about it (near a heading the walls suggest, or uniform for a share
  // of the hypotheses), then a tilt error of the candidate's spread.
  const Eigen::Quaterniond align = Eigen::Quaterniond::FromTwoVectors(c.up.cast<double>(), up);
  const double yaw = headings.empty() || rng.chance(options_.uniform_heading_share)
                         ? rng.uniform(-kPi, kPi)
                         : headings[rng.below(headings.size())] + options_.heading_std * rng.normal();
  const Eigen::Quaterniond turn(Eigen::AngleAxisd(yaw, up));
  const Eigen::Vector3d e1 = up.unitOrthogonal();
  const Eigen::Vector3d e2 = up.cross(e1);
  const double sigma = std::max(static_cast<double>(c.angle_std), options_.min_angle_std);
  const Eigen::Vector3d tilt = sigma * (rng.normal() * e1 + rng.normal() * e2);
  const Eigen::Quaterniond q = Eigen::Quaterniond(quaternion_exp(tilt.cast<float>()).cast<double>()) * turn * align;
  return q.cast<float>().normalized();
}

std::size_t GlobalProposal::blocks() const { return candidates_.size() + 1; }

double GlobalProposal::block_share(std::size_t b) const {
  if (candidates_.empty()) return b == 0 ? 1.0 : 0.0;
  if (b == 0) return options_.uniform_share;
  return (1.0 - options_.uniform_share) / static_cast<double>(candidates_.size());
}

void GlobalProposal::draw(std::size_t b, Rng& rng, Eigen::Vector3f* position, Eigen::Quaternionf* rotation) const {
  if (b == 0) {
    *position = free_space_.sample_position(rng);
    *rotation = free_space_.sample_rotation(rng);
    return;
  }
  const GravityCandidate& c = candidates_[b - 1];
  // The height the scan suggests: above the floor where its planes show the floor, otherwise above the level
  // bounding the scan from below or below the one bounding it from above, half and half (either may be off: a
  // lower floor seen beyond a ramp, a skylight). The user's height band, where given, stands for all of it.
  const auto min_std = static_cast<float>(options_.min_height_std);
  const bool floor_seen = c.has_height && c.floor_patches > 0;
  const bool use_ceiling = c.has_ceiling && !floor_seen && (!c.has_height || rng.chance(0.5));
  bool placed = false;
  if (!init_.use_height_band) {
    if (use_ceiling) {
      placed = free_space_.sample_below_ceiling(rng, c.ceiling, std::max(c.ceiling_std, min_std), position);
    } else if (c.has_height) {
      placed = free_space_.sample_above_floor(rng, c.height, std::max(c.height_std, min_std), position);
    }
  }
  if (!placed) *position = free_space_.sample_position(rng);
  *rotation = rotation_for(b - 1, rng);
}

void GlobalProposal::sample_block(std::size_t b, const ParticleArrays& p, std::size_t begin, std::size_t end,
                                  std::uint64_t seed, std::uint64_t step) const {
#pragma omp parallel for schedule(static) if (end - begin >= kParallelParticles)
  for (std::ptrdiff_t k = static_cast<std::ptrdiff_t>(begin); k < static_cast<std::ptrdiff_t>(end); ++k) {
    const auto i = static_cast<std::size_t>(k);
    Rng rng(seed, 0x960B41ull + b, step, i);
    Eigen::Vector3f position;
    Eigen::Quaternionf rotation;
    draw(b, rng, &position, &rotation);
    p.set(i, position, rotation);
  }
}

void GlobalProposal::sample(const ParticleArrays& p, std::size_t begin, std::size_t end, std::uint64_t seed,
                            std::uint64_t step) const {
#pragma omp parallel for schedule(static) if (end - begin >= kParallelParticles)
  for (std::ptrdiff_t k = static_cast<std::ptrdiff_t>(begin); k < static_cast<std::ptrdiff_t>(end); ++k) {
    const auto i = static_cast<std::size_t>(k);
    Rng rng(seed, 0x960B41ull, step, i);
    std::size_t b = 0;
    if (!candidates_.empty() && !rng.chance(options_.uniform_share)) {
      b = 1 + std::min(candidates_.size() - 1,
                       static_cast<std::size_t>(rng.uniform() * static_cast<double>(candidates_.size())));
    }
    Eigen::Vector3f position;
    Eigen::Quaternionf rotation;
    draw(b, rng, &position, &rotation);
    p.set(i, position, rotation);
  }
}

}  // namespace tsdf_mcl
