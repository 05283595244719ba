#include "tsdf_mcl/filter/particle_init.hpp"

#include <algorithm>
#include <bitset>
#include <cmath>
#include <limits>
#include <string>

#include "tsdf_mcl/sensor/endpoint_kernel.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/filter/motion_model.hpp"

namespace tsdf_mcl {
namespace {
constexpr double kPi = 3.141592653589793;
constexpr int B = TsdfMap::kBlockSize;
}  // namespace

void GlobalInitOptions::validate() const {
  if (!(max_tilt > 0.0) || !std::isfinite(max_tilt)) throw Error("init_max_tilt must be positive");
  if (!(min_clearance >= 0.0) || !std::isfinite(min_clearance)) throw Error("init_min_clearance must not be negative");
  if (use_height_band && !(max_height > min_height && std::isfinite(min_height) && std::isfinite(max_height))) {
    throw Error("init_max_height must be larger than init_min_height");
  }
}

void LocalInitSpread::validate() const {
  for (const auto& [name, v] :
       {std::pair{"init_sigma_xy", sigma_xy}, std::pair{"init_sigma_z", sigma_z},
        std::pair{"init_sigma_yaw", sigma_yaw}, std::pair{"init_sigma_roll_pitch", sigma_roll_pitch}}) {
    if (!(v >= 0.0) || !std::isfinite(v)) throw Error(std::string(name) + " must be a non-negative number");
  }
}

// What the walk of one voxel column reads (fixed for the whole map) and the block masks it fills.
struct FreeSpaceSampler::ColumnWalk {
  ColumnWalk(const TsdfMap& m, const GlobalInitOptions& o, int stride, const std::vector<std::int64_t>& slots,
             std::vector<BlockMask>& block_masks)
      : map(m),
        view(m),
        dims(m.dims_blocks()),
        coarse(m.coarse_index()),
        slot(slots),
        masks(block_masks),
        step(m.quantization_step()),
        voxel(m.voxel_size()),
        clearance(static_cast<float>(std::min<double>(o.min_clearance, m.truncation()))),
        band(o.use_height_band),
        min_h(static_cast<float>(o.min_height)),
        max_h(static_cast<float>(o.max_height)),
        z0(m.min_block().z() * B),
        floor_stride(stride) {}

  // Column l (lx + B * ly) of the blocks at (bx, by, any z), bottom to top: sets the bits of its candidate voxels
  // in their blocks' masks (only this column's bits: the walks of different columns may run in parallel) and
  // appends its floors (on the floor lattice only) to `floors`.
  void column(int bx, int by, int l, std::vector<Floor>& floors) const;

  const TsdfMap& map;
  const kernel::MapView view;
  const Eigen::Vector3i dims;
  const std::vector<std::uint32_t>& coarse;
  const std::vector<std::int64_t>& slot;  // index into masks of each known block in coarse order, else -1
  std::vector<BlockMask>& masks;
  const float step, voxel, clearance;
  const bool band;
  const float min_h, max_h;
  const int z0;  // the lowest voxel z
  const int floor_stride;
};

void FreeSpaceSampler::ColumnWalk::column(int bx, int by, int l, std::vector<Floor>& floors) const {
  const int lx = l % B, ly = l / B;
  const int vx = (map.min_block().x() + bx) * B + lx;
  const int vy = (map.min_block().y() + by) * B + ly;
  const bool floor_column = vx % floor_stride == 0 && vy % floor_stride == 0;
  // The surface height below, from the last voxel inside a surface.
  float floor_z = -std::numeric_limits<float>::infinity();
  enum class Last { kUnknown, kSurface, kFree } last = Last::kUnknown;
  Floor run{vx, vy, 0.0f, 0.0f, false};
  const auto close_run = [&](float top, bool ceiling) {
    if (last == Last::kFree && floor_column && std::isfinite(run.z) && top > run.z) {
      run.top = top;
      run.ceiling = ceiling;
      floors.push_back(run);
    }
  };
  for (int bz = 0; bz < dims.z(); ++bz) {
    const std::size_t cell =
        static_cast<std::size_t>(bx) +
        static_cast<std::size_t>(dims.x()) *
            (static_cast<std::size_t>(by) + static_cast<std::size_t>(dims.y()) * static_cast<std::size_t>(bz));
    if (coarse[cell] == TsdfMap::kUnknownBlock) {
      close_run(static_cast<float>(z0 + bz * B) * voxel - 0.5f * voxel, false);
      last = Last::kUnknown;
      continue;
    }
    BlockMask& mask = masks[static_cast<std::size_t>(slot[cell])];
    for (int lz = 0; lz < B; ++lz) {
      const int vz = z0 + bz * B + lz;
      const std::int32_t q = view.fetch(vx, vy, vz);
      const float z = static_cast<float>(vz) * voxel;
      if (q == TsdfMap::kUnknownValue) {
        close_run(z - 0.5f * voxel, false);
        last = Last::kUnknown;
        continue;
      }
      const float d = static_cast<float>(q) * step;
      if (d <= 0.0f) {
        close_run(z + d, true);  // a ceiling: its surface lies |d| below this voxel's centre
        floor_z = z - d;         // the surface lies |d| above this voxel's centre (normal pointing up)
        last = Last::kSurface;
        continue;
      }
      if (last == Last::kSurface) run.z = floor_z;
      if (last == Last::kUnknown) run.z = std::numeric_limits<float>::quiet_NaN();  // no floor seen under this run
      last = Last::kFree;
      if (d < clearance) continue;
      if (band && !(z - floor_z >= min_h && z - floor_z <= max_h)) continue;
      const int local = lx + B * (ly + B * lz);
      mask[static_cast<std::size_t>(local >> 6)] |= 1ull << (local & 63);
    }
  }
  close_run(static_cast<float>(z0 + dims.z() * B) * voxel - 0.5f * voxel, false);
}

FreeSpaceSampler::FreeSpaceSampler(const TsdfMap& map, const GlobalInitOptions& options)
    : map_(&map), options_(options) {
  options_.validate();
  if (map.empty()) throw Error("global initialization: the map is empty");
  // One mask per known block, filled in parallel by block rows (each row owns its blocks), compacted after.
  // The same column walk finds the floors: a free run of voxels starting on a surface.
  const std::vector<std::uint32_t>& coarse = map.coarse_index();
  std::vector<std::int64_t> slot(coarse.size(), -1);
  std::size_t known = 0;
  for (std::size_t c = 0; c < coarse.size(); ++c) {
    if (coarse[c] != TsdfMap::kUnknownBlock) slot[c] = static_cast<std::int64_t>(known++);
  }
  std::vector<BlockMask> masks(known, BlockMask{});
  // Floors are kept on a lateral lattice no finer than kFloorCell: a 0.05 m map's every column would cost
  // memory without adding hypotheses that differ.
  floor_stride_ = std::max(1, static_cast<int>(std::lround(kFloorCell / map.voxel_size())));
  walk_columns(ColumnWalk(map, options_, floor_stride_, slot, masks));
  if (compact_blocks(slot, masks) == 0) {
    const std::string band = options_.use_height_band
                                 ? ", height band " + std::to_string(static_cast<float>(options_.min_height)) + ".." +
                                       std::to_string(static_cast<float>(options_.max_height)) + " m"
                                 : std::string();
    throw Error("global initialization: the map has no free space that satisfies the constraints (clearance " +
                std::to_string(options_.min_clearance) + " m" + band + ")");
  }
}

void FreeSpaceSampler::walk_columns(const ColumnWalk& walk) {
  // Each block row's floors in their own list, joined in row order after: the same floors in the same order
  // however the rows are scheduled.
  std::vector<std::vector<Floor>> row_floors(static_cast<std::size_t>(walk.dims.y()));
#pragma omp parallel for schedule(dynamic)
  for (int by = 0; by < walk.dims.y(); ++by) {
    std::vector<Floor>& floors = row_floors[static_cast<std::size_t>(by)];
    for (int bx = 0; bx < walk.dims.x(); ++bx) {
      for (int l = 0; l < B * B; ++l) walk.column(bx, by, l, floors);
    }
  }
  for (const std::vector<Floor>& row : row_floors) floors_.insert(floors_.end(), row.begin(), row.end());
}

std::uint64_t FreeSpaceSampler::compact_blocks(const std::vector<std::int64_t>& slot,
                                               const std::vector<BlockMask>& masks) {
  const TsdfMap& map = *map_;
  const Eigen::Vector3i dims = map.dims_blocks();
  std::uint64_t total = 0;
  for (std::size_t c = 0; c < slot.size(); ++c) {
    if (slot[c] < 0) continue;
    const BlockMask& mask = masks[static_cast<std::size_t>(slot[c])];
    std::uint64_t count = 0;
    for (std::uint64_t word : mask) count += std::bitset<64>(word).count();
    if (count == 0) continue;
    const auto cc = static_cast<int>(c);
    block_.emplace_back(map.min_block().x() + cc % dims.x(), map.min_block().y() + (cc / dims.x()) % dims.y(),
                        map.min_block().z() + cc / (dims.x() * dims.y()));
    mask_.push_back(mask);
    total += count;
    cumulative_.push_back(total);
  }
  return total;
}

Eigen::Vector3f FreeSpaceSampler::sample_position(Rng& rng) const {
  const std::uint64_t k = rng.below(cumulative_.back());
  const auto b =
      static_cast<std::size_t>(std::upper_bound(cumulative_.begin(), cumulative_.end(), k) - cumulative_.begin());
  std::uint64_t rank = k - (b == 0 ? 0 : cumulative_[b - 1]);
  int local = 0;
  for (int word = 0; word < 8; ++word) {
    std::uint64_t bits = mask_[b][static_cast<std::size_t>(word)];
    const auto count = static_cast<std::uint64_t>(std::bitset<64>(bits).count());
    if (rank >= count) {
      rank -= count;
      continue;
    }
    for (; rank > 0; --rank) bits &= bits - 1;  // drop the lowest set bits until the wanted one is lowest
    local = word * 64 + __builtin_ctzll(bits);
    break;
  }
  const Eigen::Vector3i voxel = block_[b] * B + Eigen::Vector3i(local % B, (local / B) % B, local / (B * B));
  const float h = 0.5f * map_->voxel_size();
  const Eigen::Vector3f jitter(static_cast<float>(rng.uniform(-h, h)), static_cast<float>(rng.uniform(-h, h)),
                               static_cast<float>(rng.uniform(-h, h)));
  return map_->center_of(voxel) + jitter;
}

template <typename Place>
bool FreeSpaceSampler::sample_in_run(Rng& rng, Place&& place, Eigen::Vector3f* position) const {
  if (floors_.empty()) return false;
  const float voxel = map_->voxel_size();
  const float cell = static_cast<float>(floor_stride_) * voxel;
  const kernel::MapView view(*map_);
  for (int attempt = 0; attempt < 16; ++attempt) {
    const Floor& f = floors_[rng.below(floors_.size())];
    const float z = place(f);
    if (!(z > f.z + 0.5f * voxel && z < f.top - 0.5f * voxel)) continue;  // also NaN: no such height here
    const Eigen::Vector3f p(static_cast<float>(f.vx) * voxel + static_cast<float>(rng.uniform(-0.5, 0.5)) * cell,
                            static_cast<float>(f.vy) * voxel + static_cast<float>(rng.uniform(-0.5, 0.5)) * cell, z);
    // The lateral jitter may leave the column: keep only positions that are free where they land.
    const Eigen::Vector3i v = map_->voxel_of(p);
    const std::int32_t q = view.fetch(v.x(), v.y(), v.z());
    if (q <= 0) continue;  // occupied, or unknown (kUnknownValue is the most negative value)
    *position = p;
    return true;
  }
  return false;
}

bool FreeSpaceSampler::sample_above_floor(Rng& rng, float height, float height_std, Eigen::Vector3f* position) const {
  return sample_in_run(
      rng, [&](const Floor& f) { return f.z + height + height_std * static_cast<float>(rng.normal()); }, position);
}

bool FreeSpaceSampler::sample_below_ceiling(Rng& rng, float depth, float depth_std, Eigen::Vector3f* position) const {
  return sample_in_run(
      rng,
      [&](const Floor& f) {
        return f.ceiling ? f.top - depth - depth_std * static_cast<float>(rng.normal())
                         : std::numeric_limits<float>::quiet_NaN();
      },
      position);
}

Eigen::Quaternionf FreeSpaceSampler::sample_rotation(Rng& rng) const {
  if (options_.max_tilt >= kPi) {
    // Shoemake: uniform over the unit quaternions' 3-sphere.
    const double u1 = rng.uniform(), u2 = rng.uniform(), u3 = rng.uniform();
    const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
    return Eigen::Quaternionf(
        static_cast<float>(b * std::cos(2 * kPi * u3)), static_cast<float>(a * std::sin(2 * kPi * u2)),
        static_cast<float>(a * std::cos(2 * kPi * u2)), static_cast<float>(b * std::sin(2 * kPi * u3)));
  }
  // The sensor's z axis uniform over the spherical cap (cos of the tilt uniform), then a uniform turn about
  // it: the uniform distribution over SO(3) restricted to the cap.
  const double cos_tilt = 1.0 - rng.uniform() * (1.0 - std::cos(options_.max_tilt));
  const double tilt = std::acos(std::clamp(cos_tilt, -1.0, 1.0));
  const double azimuth = rng.uniform(0.0, 2 * kPi);
  const double yaw = rng.uniform(-kPi, kPi);
  const Eigen::Quaterniond q =
      Eigen::Quaterniond(Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(azimuth), std::sin(azimuth), 0.0))) *
      Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  return q.cast<float>().normalized();
}

void FreeSpaceSampler::sample(const ParticleArrays& p, std::size_t begin, std::size_t end, std::uint64_t seed,
                              std::uint64_t step) const {
#pragma omp parallel for schedule(static) if (end - begin >= kParallelParticles)
  for (std::ptrdiff_t k = static_cast<std::ptrdiff_t>(begin); k < static_cast<std::ptrdiff_t>(end); ++k) {
    const auto i = static_cast<std::size_t>(k);
    Rng rng(seed, 0x61080Bull, step, i);
    const Eigen::Vector3f pos = sample_position(rng);
    p.set(i, pos, sample_rotation(rng));
  }
}

void sample_local(const ParticleArrays& p, std::size_t n, const Pose& mean, const LocalInitSpread& s,
                  std::uint64_t seed, std::uint64_t step) {
  s.validate();
  const Eigen::Vector3f t = mean.translation().cast<float>();
  const Eigen::Quaternionf q(Eigen::Quaterniond(mean.linear()).cast<float>());
#pragma omp parallel for schedule(static) if (n >= kParallelParticles)
  for (std::ptrdiff_t k = 0; k < static_cast<std::ptrdiff_t>(n); ++k) {
    const auto i = static_cast<std::size_t>(k);
    Rng rng(seed, 0x10CA1ull, step, i);
    const auto g = [&rng](double sigma) { return static_cast<float>(sigma * rng.normal()); };
    const Eigen::Vector3f pos = t + Eigen::Vector3f(g(s.sigma_xy), g(s.sigma_xy), g(s.sigma_z));
    const Eigen::Vector3f w(g(s.sigma_roll_pitch), g(s.sigma_roll_pitch), g(s.sigma_yaw));
    p.set(i, pos, (q * quaternion_exp(w)).normalized());
  }
}

}  // namespace tsdf_mcl
