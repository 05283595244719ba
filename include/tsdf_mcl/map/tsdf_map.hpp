#pragma once
// A truncated signed distance field held as a two-level sparse grid, in exactly the layout the GPU reads:
//
//   voxel index v (integer, never derived from a float position except through voxel_of()),
//   centre at v * voxel_size;
//   block b = floor(v / B), B = 8, aligned to the voxel grid; local index l = lx + B*(ly + B*lz);
//   coarse index: dense uint32 array over the bounding box in blocks, cell c = bx + nx*(by + ny*bz)
//     (bx.. relative to min_block): a block number into the pool, kUnknownBlock or kFreeBlock;
//   block pool: int16 quantized distances d/truncation*32767, two per uint32 word (even l in the low half),
//     kUnknownValue for voxels never observed.
//
// kFreeBlock marks a whole block as observed free space beyond the truncation band (distance = +truncation)
// without storing 512 copies of it: free space far from surfaces is most of an indoor map.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

namespace tsdf_mcl {

class TsdfMap {
 public:
  static constexpr int kBlockSize = 8;
  static constexpr int kVoxelsPerBlock = kBlockSize * kBlockSize * kBlockSize;
  static constexpr int kWordsPerBlock = kVoxelsPerBlock / 2;
  static constexpr std::uint32_t kUnknownBlock = 0xFFFFFFFFu;
  static constexpr std::uint32_t kFreeBlock = 0xFFFFFFFEu;
  static constexpr std::int16_t kUnknownValue = INT16_MIN;
  static constexpr int kQuantMax = 32767;

  TsdfMap() = default;
  // An empty map (every block unknown) covering the blocks min_block .. min_block + dims_blocks - 1. Throws Error
  // unless the geometry lies within limits.hpp (voxel size, truncation, voxel indices, coarse cells): code that
  // reads a map never sees indices or scales whose arithmetic could overflow.
  TsdfMap(float voxel_size, float truncation, const Eigen::Vector3i& min_block, const Eigen::Vector3i& dims_blocks);
  // An empty map whose block grid covers the axis-aligned box [world_min, world_max].
  static TsdfMap covering(float voxel_size, float truncation, const Eigen::Vector3f& world_min,
                          const Eigen::Vector3f& world_max);
  // The number of coarse cells covering() would allocate (builders check it against their memory budget first).
  static std::uint64_t box_cells(float voxel_size, float truncation, const Eigen::Vector3f& world_min,
                                 const Eigen::Vector3f& world_max);
  // The constructor's checks alone, without allocating (file headers are checked before their payload is read).
  static void validate_geometry(float voxel_size, float truncation, const Eigen::Vector3i& min_block,
                                const Eigen::Vector3i& dims_blocks);
  // Assembles a map from raw buffers (file loading); validates sizes and block numbers.
  static TsdfMap from_buffers(float voxel_size, float truncation, const Eigen::Vector3i& min_block,
                              const Eigen::Vector3i& dims_blocks, std::vector<std::uint32_t> coarse,
                              std::vector<std::uint32_t> pool);

  float voxel_size() const { return voxel_size_; }
  float truncation() const { return truncation_; }
  const Eigen::Vector3i& min_block() const { return min_block_; }
  const Eigen::Vector3i& dims_blocks() const { return dims_blocks_; }
  bool empty() const { return coarse_.empty(); }

  // The buffers uploaded unchanged to the GPU.
  const std::vector<std::uint32_t>& coarse_index() const { return coarse_; }
  const std::vector<std::uint32_t>& block_pool() const { return pool_; }
  std::size_t block_count() const { return pool_.size() / kWordsPerBlock; }

  // Index arithmetic (exact integer floor division).
  Eigen::Vector3i voxel_of(const Eigen::Vector3f& world) const;  // nearest voxel centre
  Eigen::Vector3f center_of(const Eigen::Vector3i& voxel) const;
  // Arithmetic shifts and masks are floor division and modulo by 8 for negative indices too; inline, as the
  // builders call them per voxel.
  static Eigen::Vector3i block_of(const Eigen::Vector3i& voxel) {
    static_assert(kBlockSize == 8, "block_of() and local_index() shift and mask by 3 bits");
    return {voxel.x() >> 3, voxel.y() >> 3, voxel.z() >> 3};
  }
  static int local_index(const Eigen::Vector3i& voxel) {  // l within its block
    return (voxel.x() & 7) + kBlockSize * ((voxel.y() & 7) + kBlockSize * (voxel.z() & 7));
  }
  // Coarse cell of a block, or -1 outside the bounding box.
  std::int64_t coarse_cell(const Eigen::Vector3i& block) const;

  // Voxel access. Outside the box or unknown: kUnknownValue / nullopt.
  std::int16_t quantized(const Eigen::Vector3i& voxel) const;
  std::optional<float> distance(const Eigen::Vector3i& voxel) const;
  // Writes a distance (clamped to ±truncation), allocating the block (filled with unknown, or with
  // +truncation if it was a free block). Throws if the voxel is outside the box.
  void set_distance(const Eigen::Vector3i& voxel, float distance);
  void set_unknown(const Eigen::Vector3i& voxel);
  // Writes a whole block at once (builders fill blocks in parallel, then store them): quantized values in local
  // index order, kUnknownValue allowed. Allocates the block; throws if it is outside the box.
  void set_block(const Eigen::Vector3i& block, const std::array<std::int16_t, kVoxelsPerBlock>& values);
  // Marks an unallocated block as free space (+truncation everywhere). Allocated blocks are left alone.
  void mark_block_free(const Eigen::Vector3i& block);
  std::uint32_t block_entry(const Eigen::Vector3i& block) const;  // pool index or a sentinel
  // Replaces allocated blocks whose voxels are all at +truncation by kFreeBlock and blocks that are all
  // unknown by kUnknownBlock; renumbers the pool.
  void compact();

  float quantization_step() const { return truncation_ / kQuantMax; }
  std::int16_t quantize(float distance) const;
  float dequantize(std::int16_t q) const { return static_cast<float>(q) * quantization_step(); }

  // World-point lookups; these are the CPU definitions the shaders must match.
  struct Sample {
    bool known = false;
    float distance = 0.0f;
  };
  Sample nearest(const Eigen::Vector3f& world) const;
  // Trilinear over the 8 surrounding voxel centres, renormalized over the known ones;
  // unknown if none is known.
  Sample trilinear(const Eigen::Vector3f& world) const;

  Eigen::Vector3f world_min() const;  // corner of the block box (centre of its first voxel minus half a voxel)
  Eigen::Vector3f world_max() const;

  struct Stats {
    std::size_t allocated_blocks = 0;
    std::size_t free_blocks = 0;
    std::size_t known_voxels = 0;  // includes voxels of free blocks
    std::size_t free_voxels = 0;   // known with positive distance
    std::size_t memory_bytes = 0;  // coarse index + pool
  };
  Stats stats() const;

 private:
  float voxel_size_ = 0.05f;
  float truncation_ = 0.3f;
  Eigen::Vector3i min_block_ = Eigen::Vector3i::Zero();
  Eigen::Vector3i dims_blocks_ = Eigen::Vector3i::Zero();
  std::vector<std::uint32_t> coarse_;
  std::vector<std::uint32_t> pool_;

  std::uint32_t allocate_block(std::int64_t cell);
  static void block_box(float voxel_size, float truncation, const Eigen::Vector3f& world_min,
                        const Eigen::Vector3f& world_max, Eigen::Vector3i& min_block, Eigen::Vector3i& dims_blocks);
};

// Defaults for indoor LiDAR maps.
inline constexpr float kDefaultVoxelSize = 0.05f;
inline constexpr float kDefaultTruncation = 0.3f;

}  // namespace tsdf_mcl
