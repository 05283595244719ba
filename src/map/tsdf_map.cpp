#include "tsdf_mcl/map/tsdf_map.hpp"

#include "tsdf_mcl/map/map_lookup.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tsdf_mcl/core/checked_math.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/limits.hpp"

namespace tsdf_mcl {
namespace {

int floor_div(int a, int b) {
  const int q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

std::int16_t word_half(std::uint32_t word, int l) {
  return static_cast<std::int16_t>((l & 1) ? (word >> 16) : (word & 0xFFFFu));
}

}  // namespace

TsdfMap::TsdfMap(float voxel_size, float truncation, const Eigen::Vector3i& min_block,
                 const Eigen::Vector3i& dims_blocks)
    : voxel_size_(voxel_size), truncation_(truncation), min_block_(min_block), dims_blocks_(dims_blocks) {
  validate_geometry(voxel_size, truncation, min_block, dims_blocks);
  coarse_.assign(static_cast<std::size_t>(dims_blocks.cast<std::uint64_t>().prod()), kUnknownBlock);
}

void TsdfMap::validate_geometry(float voxel_size, float truncation, const Eigen::Vector3i& min_block,
                                const Eigen::Vector3i& dims_blocks) {
  if (!(voxel_size >= limits::kMinVoxelSize && voxel_size <= limits::kMaxVoxelSize)) {
    throw Error("voxel size " + std::to_string(voxel_size) + " m is outside the supported range [" +
                std::to_string(limits::kMinVoxelSize) + ", " + std::to_string(limits::kMaxVoxelSize) + "] m");
  }
  if (!(truncation >= voxel_size)) throw Error("truncation must be at least one voxel");
  if (!(truncation <= limits::kMaxTruncationVoxels * voxel_size)) {
    throw Error("truncation " + std::to_string(truncation) + " m is more than " +
                std::to_string(static_cast<int>(limits::kMaxTruncationVoxels)) + " voxels");
  }
  if ((dims_blocks.array() <= 0).any()) throw Error("map must span at least one block per axis");
  // In 64 bits: the header's values may be anywhere in int32.
  std::uint64_t cells = 1;
  for (int a = 0; a < 3; ++a) {
    const std::int64_t first = std::int64_t{min_block[a]} * kBlockSize;
    const std::int64_t end = (std::int64_t{min_block[a]} + dims_blocks[a]) * kBlockSize;
    if (first < -limits::kMaxAbsVoxelIndex || end > limits::kMaxAbsVoxelIndex) {
      throw Error("map box reaches voxel index " + std::to_string(first < -limits::kMaxAbsVoxelIndex ? first : end) +
                  ", beyond the supported +-2^24 (" +
                  std::to_string(static_cast<double>(limits::kMaxAbsVoxelIndex) * voxel_size / 1000.0) +
                  " km from the origin at this voxel size)");
    }
    cells *= static_cast<std::uint64_t>(dims_blocks[a]);
  }
  if (cells > limits::kMaxCoarseCells) throw Error("map bounding box too large (more than 2^28 blocks)");
}

void TsdfMap::block_box(float voxel_size, float truncation, const Eigen::Vector3f& world_min,
                        const Eigen::Vector3f& world_max, Eigen::Vector3i& min_block, Eigen::Vector3i& dims_blocks) {
  if (!world_min.allFinite() || !world_max.allFinite() || (world_max.array() < world_min.array()).any()) {
    throw Error("invalid map bounds");
  }
  validate_geometry(voxel_size, truncation, Eigen::Vector3i::Zero(), Eigen::Vector3i::Ones());
  Eigen::Vector3i lo, hi;
  for (int a = 0; a < 3; ++a) {
    const double vlo = std::floor(world_min[a] / voxel_size + 0.5);
    const double vhi = std::floor(world_max[a] / voxel_size + 0.5);
    if (std::abs(vlo) > limits::kMaxAbsVoxelIndex || std::abs(vhi) > limits::kMaxAbsVoxelIndex) {
      throw Error("map bounds reach " + std::to_string(std::max(std::abs(world_min[a]), std::abs(world_max[a]))) +
                  " m from the origin, beyond the supported +-2^24 voxels (" +
                  std::to_string(static_cast<double>(limits::kMaxAbsVoxelIndex) * voxel_size / 1000.0) + " km)");
    }
    lo[a] = floor_div(static_cast<int>(vlo), kBlockSize);
    hi[a] = floor_div(static_cast<int>(vhi), kBlockSize);
  }
  min_block = lo;
  dims_blocks = (hi - lo).array() + 1;
  validate_geometry(voxel_size, truncation, min_block, dims_blocks);
}

std::uint64_t TsdfMap::box_cells(float voxel_size, float truncation, const Eigen::Vector3f& world_min,
                                 const Eigen::Vector3f& world_max) {
  Eigen::Vector3i min_block, dims;
  block_box(voxel_size, truncation, world_min, world_max, min_block, dims);
  return dims.cast<std::uint64_t>().prod();
}

TsdfMap TsdfMap::covering(float voxel_size, float truncation, const Eigen::Vector3f& world_min,
                          const Eigen::Vector3f& world_max) {
  Eigen::Vector3i min_block, dims;
  block_box(voxel_size, truncation, world_min, world_max, min_block, dims);
  return TsdfMap(voxel_size, truncation, min_block, dims);
}

TsdfMap TsdfMap::from_buffers(float voxel_size, float truncation, const Eigen::Vector3i& min_block,
                              const Eigen::Vector3i& dims_blocks, std::vector<std::uint32_t> coarse,
                              std::vector<std::uint32_t> pool) {
  TsdfMap map(voxel_size, truncation, min_block, dims_blocks);
  if (coarse.size() != map.coarse_.size()) throw Error("coarse index size does not match the block box");
  if (pool.size() % kWordsPerBlock != 0) throw Error("block pool size is not a whole number of blocks");
  const std::size_t blocks = pool.size() / kWordsPerBlock;
  for (std::uint32_t entry : coarse) {
    if (entry != kUnknownBlock && entry != kFreeBlock && entry >= blocks) {
      throw Error("coarse index refers to block " + std::to_string(entry) + " of " + std::to_string(blocks));
    }
  }
  map.coarse_ = std::move(coarse);
  map.pool_ = std::move(pool);
  return map;
}

Eigen::Vector3i TsdfMap::voxel_of(const Eigen::Vector3f& world) const {
  const float inv = 1.0f / voxel_size_;
  return Eigen::Vector3i(io::saturated_floor(world.x() * inv + 0.5f), io::saturated_floor(world.y() * inv + 0.5f),
                         io::saturated_floor(world.z() * inv + 0.5f));
}

Eigen::Vector3f TsdfMap::center_of(const Eigen::Vector3i& voxel) const { return voxel.cast<float>() * voxel_size_; }

std::int64_t TsdfMap::coarse_cell(const Eigen::Vector3i& block) const {
  const Eigen::Vector3i c = block - min_block_;
  if ((c.array() < 0).any() || (c.array() >= dims_blocks_.array()).any()) return -1;
  return c.x() +
         static_cast<std::int64_t>(dims_blocks_.x()) * (c.y() + static_cast<std::int64_t>(dims_blocks_.y()) * c.z());
}

std::uint32_t TsdfMap::block_entry(const Eigen::Vector3i& block) const {
  const std::int64_t cell = coarse_cell(block);
  return cell < 0 ? kUnknownBlock : coarse_[static_cast<std::size_t>(cell)];
}

std::int16_t TsdfMap::quantized(const Eigen::Vector3i& voxel) const {
  const std::uint32_t entry = block_entry(block_of(voxel));
  if (entry == kUnknownBlock) return kUnknownValue;
  if (entry == kFreeBlock) return kQuantMax;
  const int l = local_index(voxel);
  return word_half(pool_[static_cast<std::size_t>(entry) * kWordsPerBlock + l / 2], l);
}

std::optional<float> TsdfMap::distance(const Eigen::Vector3i& voxel) const {
  const std::int16_t q = quantized(voxel);
  if (q == kUnknownValue) return std::nullopt;
  return dequantize(q);
}

std::int16_t TsdfMap::quantize(float distance) const {
  const float n = std::clamp(distance / truncation_, -1.0f, 1.0f);
  return static_cast<std::int16_t>(std::lround(n * kQuantMax));
}

std::uint32_t TsdfMap::allocate_block(std::int64_t cell) {
  std::uint32_t& entry = coarse_[static_cast<std::size_t>(cell)];
  if (entry != kUnknownBlock && entry != kFreeBlock) return entry;
  if (block_count() >= kFreeBlock) throw Error("block pool full");
  const std::uint16_t fill = static_cast<std::uint16_t>(entry == kFreeBlock ? kQuantMax : kUnknownValue);
  const std::uint32_t word = static_cast<std::uint32_t>(fill) | (static_cast<std::uint32_t>(fill) << 16);
  const auto index = static_cast<std::uint32_t>(block_count());
  pool_.insert(pool_.end(), kWordsPerBlock, word);
  entry = index;
  return index;
}

namespace {
void store(std::vector<std::uint32_t>& pool, std::size_t block, int l, std::int16_t value) {
  std::uint32_t& word = pool[block * TsdfMap::kWordsPerBlock + l / 2];
  const std::uint32_t bits = static_cast<std::uint16_t>(value);
  word = (l & 1) ? ((word & 0x0000FFFFu) | (bits << 16)) : ((word & 0xFFFF0000u) | bits);
}
}  // namespace

void TsdfMap::set_distance(const Eigen::Vector3i& voxel, float distance) {
  const std::int64_t cell = coarse_cell(block_of(voxel));
  if (cell < 0) throw Error("voxel outside the map's bounding box");
  if (!std::isfinite(distance)) throw Error("non-finite distance");
  store(pool_, allocate_block(cell), local_index(voxel), quantize(distance));
}

void TsdfMap::set_unknown(const Eigen::Vector3i& voxel) {
  const std::int64_t cell = coarse_cell(block_of(voxel));
  if (cell < 0 || coarse_[static_cast<std::size_t>(cell)] == kUnknownBlock) return;
  store(pool_, allocate_block(cell), local_index(voxel), kUnknownValue);
}

void TsdfMap::set_block(const Eigen::Vector3i& block, const std::array<std::int16_t, kVoxelsPerBlock>& values) {
  const std::int64_t cell = coarse_cell(block);
  if (cell < 0) throw Error("block outside the map's bounding box");
  const std::size_t base = static_cast<std::size_t>(allocate_block(cell)) * kWordsPerBlock;
  for (int w = 0; w < kWordsPerBlock; ++w) {
    pool_[base + static_cast<std::size_t>(w)] =
        static_cast<std::uint16_t>(values[static_cast<std::size_t>(2 * w)]) |
        (static_cast<std::uint32_t>(static_cast<std::uint16_t>(values[static_cast<std::size_t>(2 * w + 1)])) << 16);
  }
}

void TsdfMap::mark_block_free(const Eigen::Vector3i& block) {
  const std::int64_t cell = coarse_cell(block);
  if (cell >= 0 && coarse_[static_cast<std::size_t>(cell)] == kUnknownBlock)
    coarse_[static_cast<std::size_t>(cell)] = kFreeBlock;
}

void TsdfMap::compact() {
  std::vector<std::uint32_t> pool;
  pool.reserve(pool_.size());
  const std::uint32_t all_free = static_cast<std::uint32_t>(kQuantMax) | (static_cast<std::uint32_t>(kQuantMax) << 16);
  const std::uint32_t all_unknown = 0x80008000u;
  for (std::uint32_t& entry : coarse_) {
    if (entry == kUnknownBlock || entry == kFreeBlock) continue;
    const auto begin = pool_.begin() + static_cast<std::ptrdiff_t>(entry) * kWordsPerBlock;
    const auto end = begin + kWordsPerBlock;
    if (std::all_of(begin, end, [&](std::uint32_t w) { return w == all_free; })) {
      entry = kFreeBlock;
    } else if (std::all_of(begin, end, [&](std::uint32_t w) { return w == all_unknown; })) {
      entry = kUnknownBlock;
    } else {
      const auto index = static_cast<std::uint32_t>(pool.size() / kWordsPerBlock);
      pool.insert(pool.end(), begin, end);
      entry = index;
    }
  }
  pool.shrink_to_fit();
  pool_ = std::move(pool);
}

// The sensor update's own lookup (tsdf_mcl/map/map_lookup.hpp), so that a sample here is what a particle sees.
TsdfMap::Sample TsdfMap::nearest(const Eigen::Vector3f& world) const {
  const kernel::MapView view(*this);
  const float g[3] = {world.x() * view.inv_voxel, world.y() * view.inv_voxel, world.z() * view.inv_voxel};
  const std::int32_t q = kernel::sample_nearest(view, g);
  if (q == kUnknownValue) return {};
  return {true, static_cast<float>(q) * view.quant_step};
}

TsdfMap::Sample TsdfMap::trilinear(const Eigen::Vector3f& world) const {
  const kernel::MapView view(*this);
  const float g[3] = {world.x() * view.inv_voxel, world.y() * view.inv_voxel, world.z() * view.inv_voxel};
  Sample s;
  s.known = kernel::sample_trilinear(view, g, &s.distance);
  return s.known ? s : Sample{};
}

Eigen::Vector3f TsdfMap::world_min() const {
  return (min_block_.cast<float>() * kBlockSize).array() * voxel_size_ - 0.5f * voxel_size_;
}

Eigen::Vector3f TsdfMap::world_max() const {
  return ((min_block_ + dims_blocks_).cast<float>() * kBlockSize).array() * voxel_size_ - 0.5f * voxel_size_;
}

TsdfMap::Stats TsdfMap::stats() const {
  Stats s;
  s.memory_bytes = (coarse_.size() + pool_.size()) * sizeof(std::uint32_t);
  for (std::uint32_t entry : coarse_) {
    if (entry == kUnknownBlock) continue;
    if (entry == kFreeBlock) {
      ++s.free_blocks;
      s.known_voxels += kVoxelsPerBlock;
      s.free_voxels += kVoxelsPerBlock;
      continue;
    }
    ++s.allocated_blocks;
    for (int l = 0; l < kVoxelsPerBlock; ++l) {
      const std::int16_t q = word_half(pool_[static_cast<std::size_t>(entry) * kWordsPerBlock + l / 2], l);
      if (q == kUnknownValue) continue;
      ++s.known_voxels;
      if (q > 0) ++s.free_voxels;
    }
  }
  return s;
}

}  // namespace tsdf_mcl
