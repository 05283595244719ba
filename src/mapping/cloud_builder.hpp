#pragma once
// The point-cloud map builder's internals (cloud_to_tsdf.cpp's header comment has the algorithm): constants, the
// working points and their grid, sight lines, the band's blocks, and the Builder whose stages live in
// cloud_to_tsdf.cpp (1. points), cloud_orientation.cpp (2. normals, 3. orientation), cloud_band.cpp (4. the band) and
// cloud_free_space.cpp (5. free space, the map). Private to the map layer.
#include <omp.h>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <exception>
#include <limits>
#include <nanoflann.hpp>
#include <queue>
#include <unordered_map>
#include <vector>
#include "block_grid.hpp"
#include "build_budget.hpp"
#include "grid_walk.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"

namespace tsdf_mcl::cloud_build {

using Eigen::Vector3f;
using Eigen::Vector3i;
using grid::walk_until;

constexpr std::uint32_t kNone = 0xFFFFFFFFu;
// Working points stay within +-2^23 voxels (a 63-bit block key with room for neighbours; inside the map's +-2^24).
constexpr std::int32_t kMaxPointVoxel = (1 << 23) - 64;
constexpr int kRadius = 2;                // neighbourhood (voxels, Chebyshev) for outliers, normals, propagation
constexpr int kMinNeighbours = 2;         // besides the voxel itself, else isolated
constexpr float kSheet = 1.5f;            // voxels: points this close to a plane belong to its sheet
constexpr float kNearHit = 0.35f;         // m: a parallel sheet this close behind a side closes it (walls, slabs)
constexpr int kCandidates = 8;            // trajectory positions tried per point
constexpr float kKeyposeSpacing = 0.25f;  // m between the trajectory positions used
constexpr int kMinCrossings = 3;          // sight lines through a voxel behind a surface that make it free

inline Vector3i block_of(const Vector3i& v) { return TsdfMap::block_of(v); }
inline int local_of(const Vector3i& v) { return TsdfMap::local_index(v); }
inline std::uint64_t block_key(const Vector3i& b) {
  constexpr std::int64_t kBias = std::int64_t{1} << 20;
  return (static_cast<std::uint64_t>(b.x() + kBias) << 42) | (static_cast<std::uint64_t>(b.y() + kBias) << 21) |
         static_cast<std::uint64_t>(b.z() + kBias);
}

// ------------------------------------------------------------------------------------------------ downsampling

// Open addressing over voxel indices; each entry sums its points' offsets from the voxel centre (small numbers: float
// sums stay exact enough for millions of points).
class VoxelHash {
 public:
  struct Entry {
    Vector3i voxel;
    std::uint32_t count = 0;
    Vector3f sum = Vector3f::Zero();
    std::uint32_t pad = 0;
  };
  explicit VoxelHash(BuildBudget& budget) : budget_(budget) { resize(std::size_t{1} << 16); }
  ~VoxelHash() { budget_.release(table_.size() * sizeof(Entry)); }
  VoxelHash(const VoxelHash&) = delete;
  VoxelHash& operator=(const VoxelHash&) = delete;

  void add(const Vector3i& v, const Vector3f& offset) {
    std::size_t i = hash(v) & mask_;
    while (true) {
      Entry& e = table_[i];
      if (e.count == 0) {
        e.voxel = v;
        e.count = 1;
        e.sum = offset;
        if (++used_ * 2 > table_.size()) resize(table_.size() * 2);
        return;
      }
      if (e.voxel == v) {
        if (e.count < std::numeric_limits<std::uint32_t>::max()) {
          ++e.count;
          e.sum += offset;
        }
        return;
      }
      i = (i + 1) & mask_;
    }
  }
  std::size_t size() const { return used_; }
  const std::vector<Entry>& entries() const { return table_; }

 private:
  static std::size_t hash(const Vector3i& v) {
    std::uint64_t h = static_cast<std::uint32_t>(v.x()) * 0x9E3779B97F4A7C15ull;
    h ^= static_cast<std::uint32_t>(v.y()) * 0xC2B2AE3D27D4EB4Full;
    h ^= static_cast<std::uint32_t>(v.z()) * 0x165667B19E3779F9ull;
    h ^= h >> 31;
    h *= 0xBF58476D1CE4E5B9ull;
    return static_cast<std::size_t>(h ^ (h >> 29));
  }
  void resize(std::size_t capacity) {
    budget_.charge(capacity * sizeof(Entry), "one point per occupied voxel");
    std::vector<Entry> old(capacity);
    old.swap(table_);
    budget_.release(old.size() * sizeof(Entry));
    mask_ = capacity - 1;
    used_ = 0;
    for (const Entry& e : old) {
      if (e.count == 0) continue;
      std::size_t i = hash(e.voxel) & mask_;
      while (table_[i].count != 0) i = (i + 1) & mask_;
      table_[i] = e;
      ++used_;
    }
  }

  BuildBudget& budget_;
  std::vector<Entry> table_;
  std::size_t mask_ = 0, used_ = 0;
};

// ---------------------------------------------------------------------------------------------- the point grid

// Working points sorted by block and local index; per occupied block a 512-bit occupancy mask with prefix counts, so
// the point of a voxel is its block's first point plus the rank of its bit.
struct GridBlock {
  std::array<std::uint64_t, 8> mask{};
  std::array<std::uint16_t, 8> prefix{};
  std::uint32_t first = 0;
  Vector3i block = Vector3i::Zero();

  std::uint32_t find(int l) const {
    const int w = l >> 6;
    const std::uint64_t bit = std::uint64_t{1} << (l & 63);
    if (!(mask[static_cast<std::size_t>(w)] & bit)) return kNone;
    return first + prefix[static_cast<std::size_t>(w)] +
           static_cast<std::uint32_t>(__builtin_popcountll(mask[static_cast<std::size_t>(w)] & (bit - 1)));
  }
};

class PointGrid {
 public:
  // `voxels` sorted by (block key, local index).
  void build(const std::vector<Vector3i>& voxels) {
    blocks_.clear();
    index_.clear();
    for (std::size_t i = 0; i < voxels.size(); ++i) {
      const Vector3i b = block_of(voxels[i]);
      if (blocks_.empty() || blocks_.back().block != b) {
        blocks_.emplace_back();
        blocks_.back().block = b;
        blocks_.back().first = static_cast<std::uint32_t>(i);
      }
      const int l = local_of(voxels[i]);
      blocks_.back().mask[static_cast<std::size_t>(l >> 6)] |= std::uint64_t{1} << (l & 63);
    }
    index_.reserve(blocks_.size());
    for (std::size_t k = 0; k < blocks_.size(); ++k) {
      GridBlock& g = blocks_[k];
      int sum = 0;
      for (int w = 0; w < 8; ++w) {
        g.prefix[static_cast<std::size_t>(w)] = static_cast<std::uint16_t>(sum);
        sum += __builtin_popcountll(g.mask[static_cast<std::size_t>(w)]);
      }
      index_.emplace(block_key(g.block), static_cast<std::uint32_t>(k));
    }
  }
  const GridBlock* block(const Vector3i& b) const {
    const auto it = index_.find(block_key(b));
    return it == index_.end() ? nullptr : &blocks_[it->second];
  }
  const std::vector<GridBlock>& blocks() const { return blocks_; }
  std::size_t bytes() const { return blocks_.size() * (sizeof(GridBlock) + 48); }

 private:
  std::vector<GridBlock> blocks_;
  std::unordered_map<std::uint64_t, std::uint32_t> index_;
};

// The 27 blocks around one block: lookups of voxels within 8 voxels of it without hashing.
class Neighbourhood {
 public:
  Neighbourhood(const PointGrid& grid, const Vector3i& centre) : centre_(centre) {
    for (int k = 0; k < 27; ++k)
      nb_[static_cast<std::size_t>(k)] = grid.block(centre + Vector3i(k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1));
  }
  std::uint32_t find(const Vector3i& v) const {
    const Vector3i r = block_of(v) - centre_ + Vector3i::Ones();
    const GridBlock* g = nb_[static_cast<std::size_t>(r.x() + 3 * (r.y() + 3 * r.z()))];
    return g ? g->find(local_of(v)) : kNone;
  }

 private:
  Vector3i centre_;
  std::array<const GridBlock*, 27> nb_{};
};

// Calls f(block index) for every block of the grid, in parallel, with exceptions carried out of the threads.
template <typename F>
inline void parallel_blocks(std::size_t count, F&& f) {
  std::exception_ptr failure;
#pragma omp parallel for schedule(dynamic, 16)
  for (std::int64_t k = 0; k < static_cast<std::int64_t>(count); ++k) {
    try {
      f(static_cast<std::size_t>(k));
    } catch (...) {
#pragma omp critical(cloud_to_tsdf_failure)
      if (!failure) failure = std::current_exception();
    }
  }
  if (failure) std::rethrow_exception(failure);
}

// ------------------------------------------------------------------------------------------- working points

enum : std::uint8_t { kPlanar = 1, kTwoSided = 2 };
enum class Source : std::uint8_t { kUnknown, kTrajectory, kVisibility, kPropagation };

struct Working {
  std::vector<Vector3i> voxel;
  std::vector<Vector3f> anchor;  // the point: the voxel's average, moved onto its sheet's plane if planar
  std::vector<Vector3f> normal;  // unit, oriented where orient != 0
  std::vector<std::uint32_t> count;
  std::vector<std::uint8_t> flags;
  std::vector<std::int8_t> orient;  // +1 normal as stored, 0 unknown (normals are flipped in place once known)
  std::vector<Source> source;
  std::vector<float> confidence;
  std::vector<std::array<std::uint32_t, 2>> viewpoint;  // keyposes that see the point (kNone if none)

  std::size_t size() const { return voxel.size(); }
  bool is_signed(std::size_t i) const { return (flags[i] & kPlanar) && !(flags[i] & kTwoSided) && orient[i] != 0; }
};

// The neighbours of point i within kRadius (not i itself).
template <typename F>
inline void for_each_neighbour(const Neighbourhood& nb, const Vector3i& v, std::uint32_t self, F&& f) {
  for (int dz = -kRadius; dz <= kRadius; ++dz)
    for (int dy = -kRadius; dy <= kRadius; ++dy)
      for (int dx = -kRadius; dx <= kRadius; ++dx) {
        const std::uint32_t j = nb.find(v + Vector3i(dx, dy, dz));
        if (j != kNone && j != self) f(j);
      }
}

// ------------------------------------------------------------------------------------------------- sight lines

// Walks the segment from `from` along unit `dir` for `length`, calling hit(point, t) for each occupied voxel (in
// order) until it returns false. Returns false if stopped by hit.
template <typename Hit>
inline bool trace(const PointGrid& grid, float vs, const Vector3f& from, const Vector3f& dir, float length, Hit&& hit) {
  return walk_until(from, dir, 0.0f, length, vs, B, [&](const Vector3i& block, float t_in, float t_out) {
    const GridBlock* g = grid.block(block);
    if (!g) return true;
    return walk_until(from, dir, t_in, t_out, vs, 1, [&](const Vector3i& v, float t, float) {
      if (block_of(v) != block) return true;  // rounding at the block's faces
      const std::uint32_t j = g->find(local_of(v));
      return j == kNone || hit(j, t);
    });
  });
}

class Keyposes {
 public:
  explicit Keyposes(const std::vector<Vector3f>& trajectory) {
    for (const Vector3f& p : trajectory) {
      if (!p.allFinite()) throw Error("trajectory has a non-finite position");
      if (points_.empty() || (p - points_.back()).norm() >= kKeyposeSpacing) points_.push_back(p);
    }
    if (!points_.empty()) {
      tree_ = std::make_unique<Tree>(3, *this, nanoflann::KDTreeSingleIndexAdaptorParams(10));
      tree_->buildIndex();
    }
  }
  // nanoflann's dataset interface.
  std::size_t kdtree_get_point_count() const { return points_.size(); }
  float kdtree_get_pt(std::uint32_t i, std::size_t dim) const { return points_[i][static_cast<int>(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }

  const std::vector<Vector3f>& points() const { return points_; }
  bool empty() const { return points_.empty(); }
  // Up to k nearest, nearest first.
  std::size_t nearest(const Vector3f& p, std::size_t k, std::uint32_t* index, float* dist2) const {
    return tree_->knnSearch(p.data(), std::min(k, points_.size()), index, dist2);
  }

 private:
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Keyposes>, Keyposes, 3>;
  std::vector<Vector3f> points_;
  std::unique_ptr<Tree> tree_;
};

// Directions spread evenly over the sphere (a Fibonacci lattice): fixed, so results do not depend on threads.
inline std::vector<Vector3f> sphere_directions(int n) {
  std::vector<Vector3f> d;
  const float golden = 3.14159265f * (3.0f - std::sqrt(5.0f));
  for (int i = 0; i < n; ++i) {
    const float z = 1.0f - (2.0f * static_cast<float>(i) + 1.0f) / static_cast<float>(n);
    const float r = std::sqrt(1.0f - z * z);
    d.emplace_back(r * std::cos(golden * static_cast<float>(i)), r * std::sin(golden * static_cast<float>(i)), z);
  }
  return d;
}

struct SightLine {
  Vector3f from, to;
};

// ----------------------------------------------------------------------------------------------------- the band

struct FireBlock {
  std::array<std::uint32_t, kVoxels> nearest;
  std::array<std::uint8_t, kVoxels> layer;
  FireBlock() {
    nearest.fill(kNone);
    layer.fill(0);
  }
};

struct BandBlock {
  std::array<std::int16_t, kVoxels> q;                       // quantized distance, or its magnitude where unsure
  std::array<std::uint64_t, 8> unsure{};                     // sign unknown
  std::array<std::atomic<std::uint8_t>, kVoxels> crossed{};  // sight lines through the voxel (saturating)
  BandBlock() { q.fill(TsdfMap::kUnknownValue); }
};

class Progress {
 public:
  explicit Progress(const ProgressFn& fn) : fn_(fn) {}
  // Stage s of kStages, fraction f of it.
  void operator()(int stage, double f) const {
    if (fn_) fn_(static_cast<std::size_t>(1000.0 * (stage + std::clamp(f, 0.0, 1.0)) / kStages), 1000);
  }
  static constexpr int kStages = 6;

 private:
  const ProgressFn& fn_;
};

inline void validate(const CloudMapOptions& o) {
  if (!(o.voxel_size > 0.0f) || !std::isfinite(o.voxel_size)) {
    throw Error("voxel size must be positive, got " + std::to_string(o.voxel_size));
  }
  if (!(o.truncation >= o.voxel_size) || !std::isfinite(o.truncation)) {
    throw Error("truncation (" + std::to_string(o.truncation) + " m) must be at least the voxel size (" +
                std::to_string(o.voxel_size) + " m)");
  }
  if (!(o.margin >= 0.0f) || !std::isfinite(o.margin)) throw Error("margin must not be negative");
  if (!(o.max_range > 0.0f) || !std::isfinite(o.max_range)) throw Error("max range must be positive");
  TsdfMap::validate_geometry(o.voxel_size, o.truncation, Vector3i::Zero(), Vector3i::Ones());
}

class Builder {
 public:
  Builder(const CloudMapOptions& o, const ProgressFn& progress, CloudMapReport& report)
      : o_(o),
        vs_(o.voxel_size),
        trunc_(o.truncation),
        budget_(o.max_memory_bytes),
        progress_(progress),
        report_(report),
        keyposes_(o.trajectory) {}

  TsdfMap run(PointSource& source) {
    auto last = std::chrono::steady_clock::now();
    const auto lap = [&last](double& seconds) {
      const auto now = std::chrono::steady_clock::now();
      seconds = std::chrono::duration<double>(now - last).count();
      last = now;
    };
    downsample(source);
    drop_isolated();
    lap(report_.read_seconds);
    fit_normals();
    lap(report_.normal_seconds);
    if (!keyposes_.empty()) {
      orient_by_trajectory();
    } else {
      orient_by_visibility();
    }
    propagate_orientation();
    count_kinds();
    lap(report_.orient_seconds);
    make_box();
    brushfire();
    signed_distances();
    lap(report_.distance_seconds);
    carve();
    if (o_.fill_free_space) fill_enclosed();
    TsdfMap map = assemble();
    lap(report_.free_seconds);
    count_surface(map);
    return map;
  }

 private:
  // ---------------------------------------------------------------------------------------------- 1. points
  void downsample(PointSource& source);

  void drop_isolated();

  // ------------------------------------------------------------------------------------------------ 2. normals
  void fit_normals();

  // PCA of the points (of those within `sheet` of the plane through points[0] with normal *plane, if given).
  // Eigenvalues ascending. False if fewer than 5 points take part.
  static bool pca(const std::vector<Vector3f>& points, const Vector3f* plane, float sheet, Vector3f& normal,
                  Vector3f& mean, Vector3f& lambda);

  // --------------------------------------------------------------------------------------------- 3. orientation
  // A point's sight line to `target` is clear if it crosses no occupied voxel off the point's own sheet (planar) or
  // farther than two voxels from it (other points).
  bool sees(std::uint32_t i, const Vector3f& target) const;

  void orient_by_trajectory();

  // Without a trajectory: rays to both sides of each planar point (every fourth, spread by a hash: enough to seed
  // the propagation and to carve the space between surfaces).
  void orient_by_visibility();

  // One planar point's sight lines along the directions within 60 deg of its normal either way: per side (0: along the
  // normal), the lines that reach a surface far off and those that meet a parallel one close by; `seen` holds the
  // far surface point each direction reached (kNone if none).
  struct SightVotes {
    int far[2] = {0, 0}, close[2] = {0, 0};
    std::array<std::uint32_t, 24> seen;
  };
  SightVotes look_both_ways(std::uint32_t i, const std::vector<Vector3f>& dirs, const Vector3f& lo, const Vector3f& hi,
                            float near, float sheet) const;

  // Two-sided, or oriented towards the side with the better score; false where the votes decide nothing.
  bool orient_by_votes(std::uint32_t i, const SightVotes& votes);

  // Most confident first, each undecided planar point takes the side of the neighbour on its sheet that reaches it
  // first (normals at least 45 deg apart do not pass it on: creases are where orientations go wrong).
  void propagate_orientation();

  const GridBlock* last_block(const Vector3i& v);

  void count_kinds();

  // ------------------------------------------------------------------------------------------------ 4. the band
  void make_box();

  std::uint32_t slot_of(const Vector3i& block, bool allocate);

  // Nearest working point of every voxel within the truncation (Chebyshev layers; each voxel takes the nearest of
  // the points its neighbours in the previous layer carry, which is within a small fraction of a voxel of exact).
  // Then, within the blocks reached, the rest of the voxels (beyond the truncation: +-truncation, as the mesh builder
  // fills its band blocks). Layers hold (band block, local index) pairs.
  void brushfire();

  void signed_distances();

  // +1 or -1 if at least three signed points within kRadius of voxel centre x see it on the same side of their plane
  // (and not within half a voxel of it), else 0.
  int vote(const Neighbourhood& nb, const Vector3f& x) const;

  // --------------------------------------------------------------------------------------------- 5. free space
  void carve();

  // Connected regions of unknown blocks away from surfaces, enclosed (not touching the box's border): free if the
  // surfaces and free blocks around them mostly face them with free space.
  void fill_enclosed();

  TsdfMap assemble();

  void count_surface(const TsdfMap& map);

  const CloudMapOptions& o_;
  const float vs_, trunc_;
  BuildBudget budget_;
  Progress progress_;
  CloudMapReport& report_;
  Keyposes keyposes_;
  Working w_;
  PointGrid grid_;
  Vector3i cached_block_ = Vector3i::Constant(std::numeric_limits<int>::min());
  const GridBlock* cached_ = nullptr;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> surface_hits_;  // (point, the surface it sees)
  TsdfMap map_;
  std::vector<std::uint32_t> slot_;                    // per coarse cell: band block or kNone
  std::unique_ptr<std::atomic<std::uint8_t>[]> free_;  // per coarse cell: crossed by a sight line (1), enclosed (2)
  std::deque<FireBlock> fire_;
  std::deque<BandBlock> band_;
  std::vector<Vector3i> band_block_;
};

}  // namespace tsdf_mcl::cloud_build
