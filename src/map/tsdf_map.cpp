#include "tsdf_mcl/tsdf_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "tsdf_mcl/error.hpp"

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
  if (!(voxel_size > 0.0f) || !std::isfinite(voxel_size)) throw Error("voxel size must be positive");
  if (!(truncation >= voxel_size) || !std::isfinite(truncation)) {
    throw Error("truncation must be at least one voxel");
  }
  if ((dims_blocks.array() <= 0).any()) throw Error("map must span at least one block per axis");
  const double cells = static_cast<double>(dims_blocks.x()) * dims_blocks.y() * dims_blocks.z();
  if (cells > 256.0 * 1024 * 1024) throw Error("map bounding box too large (more than 2^28 blocks)");
  coarse_.assign(static_cast<std::size_t>(cells), kUnknownBlock);
}

TsdfMap TsdfMap::covering(float voxel_size, float truncation, const Eigen::Vector3f& world_min,
                          const Eigen::Vector3f& world_max) {
  if (!world_min.allFinite() || !world_max.allFinite() || (world_max.array() < world_min.array()).any()) {
    throw Error("invalid map bounds");
  }
  if (!(voxel_size > 0.0f)) throw Error("voxel size must be positive");
  Eigen::Vector3i lo, hi;
  for (int a = 0; a < 3; ++a) {
    const double vlo = std::floor(world_min[a] / voxel_size + 0.5);
    const double vhi = std::floor(world_max[a] / voxel_size + 0.5);
    if (std::abs(vlo) > 1e9 || std::abs(vhi) > 1e9) throw Error("map bounds too far from the origin");
    lo[a] = floor_div(static_cast<int>(vlo), kBlockSize);
    hi[a] = floor_div(static_cast<int>(vhi), kBlockSize);
  }
  return TsdfMap(voxel_size, truncation, lo, (hi - lo).array() + 1);
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
  return Eigen::Vector3i(static_cast<int>(std::floor(world.x() * inv + 0.5f)),
                         static_cast<int>(std::floor(world.y() * inv + 0.5f)),
                         static_cast<int>(std::floor(world.z() * inv + 0.5f)));
}

Eigen::Vector3f TsdfMap::center_of(const Eigen::Vector3i& voxel) const {
  return voxel.cast<float>() * voxel_size_;
}

Eigen::Vector3i TsdfMap::block_of(const Eigen::Vector3i& voxel) {
  return {floor_div(voxel.x(), kBlockSize), floor_div(voxel.y(), kBlockSize), floor_div(voxel.z(), kBlockSize)};
}

int TsdfMap::local_index(const Eigen::Vector3i& voxel) {
  const Eigen::Vector3i l = voxel - block_of(voxel) * kBlockSize;
  return l.x() + kBlockSize * (l.y() + kBlockSize * l.z());
}

std::int64_t TsdfMap::coarse_cell(const Eigen::Vector3i& block) const {
  const Eigen::Vector3i c = block - min_block_;
  if ((c.array() < 0).any() || (c.array() >= dims_blocks_.array()).any()) return -1;
  return c.x() + static_cast<std::int64_t>(dims_blocks_.x()) * (c.y() + static_cast<std::int64_t>(dims_blocks_.y()) * c.z());
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
    pool_[base + static_cast<std::size_t>(w)] = static_cast<std::uint16_t>(values[static_cast<std::size_t>(2 * w)]) |
                                                (static_cast<std::uint32_t>(static_cast<std::uint16_t>(values[static_cast<std::size_t>(2 * w + 1)])) << 16);
  }
}

void TsdfMap::mark_block_free(const Eigen::Vector3i& block) {
  const std::int64_t cell = coarse_cell(block);
  if (cell >= 0 && coarse_[static_cast<std::size_t>(cell)] == kUnknownBlock) coarse_[static_cast<std::size_t>(cell)] = kFreeBlock;
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

TsdfMap::Sample TsdfMap::nearest(const Eigen::Vector3f& world) const {
  const std::int16_t q = quantized(voxel_of(world));
  if (q == kUnknownValue) return {};
  return {true, dequantize(q)};
}

TsdfMap::Sample TsdfMap::trilinear(const Eigen::Vector3f& world) const {
  const float inv = 1.0f / voxel_size_;
  const Eigen::Vector3f g = world * inv;
  const Eigen::Vector3f base(std::floor(g.x()), std::floor(g.y()), std::floor(g.z()));
  const Eigen::Vector3f f = g - base;
  const Eigen::Vector3i v0 = base.cast<int>();
  float weight = 0.0f;
  float sum = 0.0f;
  for (int corner = 0; corner < 8; ++corner) {
    const int dx = corner & 1, dy = (corner >> 1) & 1, dz = (corner >> 2) & 1;
    const std::int16_t q = quantized(v0 + Eigen::Vector3i(dx, dy, dz));
    if (q == kUnknownValue) continue;
    const float w = (dx ? f.x() : 1.0f - f.x()) * (dy ? f.y() : 1.0f - f.y()) * (dz ? f.z() : 1.0f - f.z());
    weight += w;
    sum += w * static_cast<float>(q);
  }
  // Below this the known corners carry almost no weight: the point is effectively in unknown space.
  if (weight < 1e-3f) return {};
  return {true, sum / weight * quantization_step()};
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
