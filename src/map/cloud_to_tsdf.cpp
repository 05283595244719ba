// Point cloud -> TSDF.
//
//  1. Working points: the cloud streams through a voxel hash at the map's voxel size; each occupied voxel keeps the
//     average of its points (one working point per voxel: duplicates and dense overlaps of SLAM maps cost nothing).
//     Voxels with fewer than 3 occupied voxels within 2 voxels are dropped as outliers.
//  2. Normals: PCA over the working points within 2 voxels, then again over those of them within 1.5 voxels of the
//     first plane (the same sheet): the other face of a thin wall drops out, the two sheets of a drifted double wall
//     a few cm apart merge, and the point moves onto the sheet's mean plane. Points without a clear plane (poles,
//     edges of thin things, clutter) keep no normal.
//  3. Orientation. With a trajectory: each point's nearest trajectory positions are tried in turn; a position sees the
//     point if the sight line crosses no occupied voxel off the point's own sheet; the normal faces the positions that
//     see it. Without one: rays from the point to both sides of its plane; the side whose rays reach other surfaces
//     is open, the side whose rays hit a parallel sheet within kNearHit (the other face of a wall or slab) is closed.
//     Points still undecided take the orientation of oriented neighbours on the same sheet, most confident first (a
//     minimum-spanning-tree style propagation). Points seen from both sides are two-sided.
//  4. Distances: a brushfire from the working points gives every voxel within the truncation its nearest point; the
//     value is the distance to that point's tangent plane (growing into the Euclidean distance beside the point's
//     footprint), signed by its normal. Where that sign is not known -- beside the edge of a surface, near two-sided
//     sheets and points without a normal -- oriented points around that agree decide it; else only the distance is
//     known: such voxels become positive where free space reaches them, else unknown (a voxel within half a voxel of
//     its point stays positive: it marks the surface). The rest of the blocks reached get +-truncation.
//  5. Free space: carved along the sight lines (trajectory positions -> point, or point -> the surface it sees), block
//     by block away from surfaces and voxel by voxel in blocks near them, as the scan integrator does (and more than
//     two voxels behind a surface where several lines cross: the far side of something thin); then unknown
//     regions that are enclosed (not touching the box's border) and mostly face free space or positive surfaces
//     become free, as the mesh builder does.
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

#include "build_budget.hpp"
#include "grid_walk.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/map/map_builder.hpp"

namespace tsdf_mcl {
namespace {

using Eigen::Vector3f;
using Eigen::Vector3i;
using grid::walk_until;

constexpr int B = TsdfMap::kBlockSize;
constexpr int kVoxels = TsdfMap::kVoxelsPerBlock;
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

static_assert(B == 8, "block_of() and local() shift and mask by 3 bits");
Vector3i block_of(const Vector3i& v) { return {v.x() >> 3, v.y() >> 3, v.z() >> 3}; }
int local_of(const Vector3i& v) { return (v.x() & 7) + B * ((v.y() & 7) + B * (v.z() & 7)); }
std::uint64_t block_key(const Vector3i& b) {
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
void parallel_blocks(std::size_t count, F&& f) {
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
void for_each_neighbour(const Neighbourhood& nb, const Vector3i& v, std::uint32_t self, F&& f) {
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
bool trace(const PointGrid& grid, float vs, const Vector3f& from, const Vector3f& dir, float length, Hit&& hit) {
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
std::vector<Vector3f> sphere_directions(int n) {
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

void validate(const CloudMapOptions& o) {
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
  void downsample(PointSource& source) {
    VoxelHash hash(budget_);
    std::vector<Vector3f> chunk;
    const double inv = 1.0 / static_cast<double>(vs_);
    const std::uint64_t total = source.size_hint();
    while (source.next(chunk, std::size_t{1} << 20)) {
      for (const Vector3f& p : chunk) {
        ++report_.input_points;
        if (!p.allFinite()) {
          ++report_.non_finite;
          continue;
        }
        Vector3i v;
        bool inside = true;
        for (int a = 0; a < 3; ++a) {
          const double g = std::floor(static_cast<double>(p[a]) * inv + 0.5);
          inside = inside && std::abs(g) <= kMaxPointVoxel;
          v[a] = inside ? static_cast<int>(g) : 0;
        }
        if (!inside) {
          ++report_.out_of_range;
          continue;
        }
        hash.add(v, p - v.cast<float>() * vs_);
      }
      if (total > 0) progress_(0, static_cast<double>(report_.input_points) / static_cast<double>(total));
    }
    if (hash.size() == 0) {
      throw Error("the cloud has no usable point (" + std::to_string(report_.input_points) + " read, " +
                  std::to_string(report_.non_finite) + " not finite, " + std::to_string(report_.out_of_range) +
                  " farther than " + std::to_string(static_cast<double>(kMaxPointVoxel) * vs_ / 1000.0) +
                  " km from the origin)");
    }
    // Sorted by block, then local index: the grid's layout.
    std::vector<std::pair<std::uint64_t, std::uint32_t>> order;
    budget_.charge(hash.size() * (sizeof(order[0]) + 2 * sizeof(Vector3f) + sizeof(Vector3i) + 48),
                   "the working points");
    order.reserve(hash.size());
    const auto& entries = hash.entries();
    for (std::size_t i = 0; i < entries.size(); ++i) {
      if (entries[i].count == 0) continue;
      const Vector3i& v = entries[i].voxel;
      order.emplace_back((block_key(block_of(v)) << 9) | static_cast<std::uint64_t>(local_of(v)),
                         static_cast<std::uint32_t>(i));
    }
    std::sort(order.begin(), order.end());
    w_.voxel.reserve(order.size());
    w_.anchor.reserve(order.size());
    w_.count.reserve(order.size());
    for (const auto& [key, i] : order) {
      const VoxelHash::Entry& e = entries[i];
      w_.voxel.push_back(e.voxel);
      w_.anchor.push_back(e.voxel.cast<float>() * vs_ + e.sum / static_cast<float>(e.count));
      w_.count.push_back(e.count);
    }
    grid_.build(w_.voxel);
  }

  void drop_isolated() {
    const std::size_t n = w_.size();
    std::vector<std::uint8_t> keep(n, 0);
    const auto& blocks = grid_.blocks();
    parallel_blocks(blocks.size(), [&](std::size_t k) {
      const Neighbourhood nb(grid_, blocks[k].block);
      const std::uint32_t end = k + 1 < blocks.size() ? blocks[k + 1].first : static_cast<std::uint32_t>(n);
      for (std::uint32_t i = blocks[k].first; i < end; ++i) {
        int neighbours = 0;
        for_each_neighbour(nb, w_.voxel[i], i, [&](std::uint32_t) { ++neighbours; });
        keep[i] = neighbours >= kMinNeighbours;
      }
    });
    std::size_t out = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (!keep[i]) {
        ++report_.isolated_voxels;
        report_.isolated_points += w_.count[i];
        continue;
      }
      w_.voxel[out] = w_.voxel[i];
      w_.anchor[out] = w_.anchor[i];
      w_.count[out] = w_.count[i];
      ++out;
    }
    if (out == 0) {
      throw Error("every one of the cloud's " + std::to_string(n) + " occupied voxels is isolated (fewer than " +
                  std::to_string(kMinNeighbours) + " occupied voxels within " + std::to_string(kRadius) +
                  " voxels): the cloud is too sparse for " + std::to_string(vs_) + " m voxels");
    }
    w_.voxel.resize(out);
    w_.anchor.resize(out);
    w_.count.resize(out);
    report_.voxels = out;
    report_.used_points = report_.input_points - report_.non_finite - report_.out_of_range - report_.isolated_points;
    grid_.build(w_.voxel);
    budget_.charge(grid_.bytes(), "the occupied blocks");
    progress_(1, 0.1);
  }

  // ------------------------------------------------------------------------------------------------ 2. normals
  void fit_normals() {
    const std::size_t n = w_.size();
    budget_.charge(n * (sizeof(Vector3f) + 2 + sizeof(Source) + sizeof(float) + 8), "the working points' normals");
    w_.normal.assign(n, Vector3f::Zero());
    w_.flags.assign(n, 0);
    w_.orient.assign(n, 0);
    w_.source.assign(n, Source::kUnknown);
    w_.confidence.assign(n, 0.0f);
    w_.viewpoint.assign(n, {kNone, kNone});
    const std::vector<Vector3f> centroid = w_.anchor;
    const float sheet = kSheet * vs_;
    const auto& blocks = grid_.blocks();
    parallel_blocks(blocks.size(), [&](std::size_t k) {
      const Neighbourhood nb(grid_, blocks[k].block);
      const std::uint32_t end = k + 1 < blocks.size() ? blocks[k + 1].first : static_cast<std::uint32_t>(n);
      std::vector<Vector3f> near;
      for (std::uint32_t i = blocks[k].first; i < end; ++i) {
        near.clear();
        near.push_back(centroid[i]);
        for_each_neighbour(nb, w_.voxel[i], i, [&](std::uint32_t j) { near.push_back(centroid[j]); });
        Vector3f normal, mean;
        Vector3f lambda;
        if (!pca(near, nullptr, 0.0f, normal, mean, lambda)) continue;
        // Again over the sheet of the first plane only.
        if (!pca(near, &normal, sheet, normal, mean, lambda)) continue;
        const bool flat = lambda[0] <= 0.3f * lambda[1];
        const bool wide = lambda[1] >= 0.1f * lambda[2];
        if (!(flat && wide)) continue;
        w_.normal[i] = normal;
        w_.flags[i] = kPlanar;
        w_.anchor[i] = centroid[i] + normal * normal.dot(mean - centroid[i]);
      }
    });
    progress_(1, 1.0);
  }

  // PCA of the points (of those within `sheet` of the plane through points[0] with normal *plane, if given).
  // Eigenvalues ascending. False if fewer than 5 points take part.
  static bool pca(const std::vector<Vector3f>& points, const Vector3f* plane, float sheet, Vector3f& normal,
                  Vector3f& mean, Vector3f& lambda) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int used = 0;
    const Vector3f origin = points[0];
    auto take = [&](const Vector3f& p) { return !plane || std::abs(plane->dot(p - origin)) <= sheet; };
    for (const Vector3f& p : points) {
      if (!take(p)) continue;
      sum += (p - origin).cast<double>();
      ++used;
    }
    if (used < 5) return false;
    const Eigen::Vector3d m = sum / used;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const Vector3f& p : points) {
      if (!take(p)) continue;
      const Eigen::Vector3d d = (p - origin).cast<double>() - m;
      cov += d * d.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
    es.computeDirect(cov / used);
    normal = es.eigenvectors().col(0).cast<float>().normalized();
    lambda = es.eigenvalues().cast<float>();
    mean = origin + m.cast<float>();
    return normal.allFinite();
  }

  // --------------------------------------------------------------------------------------------- 3. orientation
  // A point's sight line to `target` is clear if it crosses no occupied voxel off the point's own sheet (planar) or
  // farther than two voxels from it (other points).
  bool sees(std::uint32_t i, const Vector3f& target) const {
    const Vector3f& p = w_.anchor[i];
    const Vector3f ray = target - p;
    const float length = ray.norm();
    if (!(length > 0.0f)) return true;
    const Vector3f dir = ray / length;
    const bool planar = w_.flags[i] & kPlanar;
    const Vector3f& n = w_.normal[i];
    const float sheet = kSheet * vs_, near2 = 4.0f * vs_ * vs_;
    return trace(grid_, vs_, p, dir, length, [&](std::uint32_t j, float) {
      if (j == i) return true;
      const Vector3f d = w_.anchor[j] - p;
      return planar ? std::abs(n.dot(d)) <= sheet : d.squaredNorm() <= near2;
    });
  }

  void orient_by_trajectory() {
    const std::size_t n = w_.size();
    const auto& poses = keyposes_.points();
    const float range2 = o_.max_range * o_.max_range;
    std::atomic<std::size_t> done{0};
    const auto& blocks = grid_.blocks();
    parallel_blocks(blocks.size(), [&](std::size_t k) {
      const std::uint32_t end = k + 1 < blocks.size() ? blocks[k + 1].first : static_cast<std::uint32_t>(n);
      std::uint32_t index[kCandidates];
      float dist2[kCandidates];
      for (std::uint32_t i = blocks[k].first; i < end; ++i) {
        const Vector3f& p = w_.anchor[i];
        const std::size_t found = keyposes_.nearest(p, kCandidates, index, dist2);
        const bool planar = w_.flags[i] & kPlanar;
        int side[2] = {0, 0};  // positions seeing the point in front of (0) and behind (1) its normal
        std::uint32_t seen[2][2] = {{kNone, kNone}, {kNone, kNone}};  // the first two seeing each side
        for (std::size_t c = 0; c < found && dist2[c] <= range2; ++c) {
          const Vector3f& pose = poses[index[c]];
          if (!sees(i, pose)) continue;
          const float cosine = planar ? w_.normal[i].dot(pose - p) / std::sqrt(dist2[c]) : 1.0f;
          const int s = cosine >= 0.0f ? 0 : 1;
          std::uint32_t* slot = seen[s];
          if (slot[0] == kNone)
            slot[0] = index[c];
          else if (slot[1] == kNone)
            slot[1] = index[c];
          if (!planar) {
            if (slot[1] != kNone) break;
            continue;
          }
          // Within ~6 deg of the plane a position tells nothing about the side.
          if (std::abs(cosine) < 0.1f) continue;
          if (++side[s] >= 3) break;
        }
        // Two sight lines per point (more lines cross the space over thin things seen from one side).
        w_.viewpoint[i] = {seen[0][0], seen[0][1]};
        if (!planar) continue;
        if (std::min(side[0], side[1]) >= 2) {
          w_.flags[i] |= kTwoSided;
          w_.viewpoint[i] = {seen[0][0], seen[1][0]};  // one from each side
        } else if (side[0] != side[1]) {
          const int front = side[1] > side[0] ? 1 : 0;
          if (front == 1) w_.normal[i] = -w_.normal[i];
          w_.viewpoint[i] = {seen[front][0], seen[front][1]};
          w_.orient[i] = 1;
          w_.source[i] = Source::kTrajectory;
          w_.confidence[i] = 1.0f + static_cast<float>(std::abs(side[0] - side[1]));
        } else {
          w_.viewpoint[i] = {seen[0][0], seen[1][0]};
        }
      }
      const std::size_t d = done.fetch_add(end - blocks[k].first) + (end - blocks[k].first);
      if (omp_get_thread_num() == 0) progress_(2, static_cast<double>(d) / static_cast<double>(n));
    });
  }

  // Without a trajectory: rays to both sides of each planar point (every fourth, spread by a hash: enough to seed
  // the propagation and to carve the space between surfaces).
  void orient_by_visibility() {
    const std::size_t n = w_.size();
    const std::vector<Vector3f> dirs = sphere_directions(24);
    Vector3f lo = Vector3f::Constant(std::numeric_limits<float>::infinity()), hi = -lo;
    for (const Vector3f& p : w_.anchor) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const float near = std::max(kNearHit, 3.0f * vs_), sheet = kSheet * vs_;
    std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> hits(
        static_cast<std::size_t>(omp_get_max_threads()));
    std::atomic<std::size_t> done{0};
    const auto& blocks = grid_.blocks();
    parallel_blocks(blocks.size(), [&](std::size_t k) {
      const std::uint32_t end = k + 1 < blocks.size() ? blocks[k + 1].first : static_cast<std::uint32_t>(n);
      auto& my_hits = hits[static_cast<std::size_t>(omp_get_thread_num())];
      for (std::uint32_t i = blocks[k].first; i < end; ++i) {
        if (!(w_.flags[i] & kPlanar)) continue;
        const Vector3i& v = w_.voxel[i];
        if (((static_cast<std::uint32_t>(v.x()) * 73856093u) ^ (static_cast<std::uint32_t>(v.y()) * 19349663u) ^
             (static_cast<std::uint32_t>(v.z()) * 83492791u)) %
                4 !=
            0) {
          continue;
        }
        const Vector3f& p = w_.anchor[i];
        const Vector3f& nrm = w_.normal[i];
        int far[2] = {0, 0}, close[2] = {0, 0};
        std::array<std::uint32_t, 24> seen;
        seen.fill(kNone);
        for (std::size_t d = 0; d < dirs.size(); ++d) {
          const float c = dirs[d].dot(nrm);
          if (std::abs(c) < 0.5f) continue;
          const int s = c > 0.0f ? 0 : 1;
          // To the first point off this point's sheet, or out of the cloud's box.
          float length = o_.max_range;
          for (int a = 0; a < 3; ++a) {
            if (dirs[d][a] > 0.0f) length = std::min(length, (hi[a] + vs_ - p[a]) / dirs[d][a]);
            if (dirs[d][a] < 0.0f) length = std::min(length, (lo[a] - vs_ - p[a]) / dirs[d][a]);
          }
          std::uint32_t hit = kNone;
          float at = 0.0f;
          trace(grid_, vs_, p, dirs[d], std::max(length, 0.0f), [&](std::uint32_t j, float t) {
            if (j == i || std::abs(nrm.dot(w_.anchor[j] - p)) <= sheet) return true;
            hit = j;
            at = t;
            return false;
          });
          if (hit == kNone) continue;  // escaped: unobserved space, no vote
          if (at < near && std::abs(w_.normal[hit].dot(nrm)) > 0.7f) {
            ++close[s];
          } else if (at >= near) {
            ++far[s];
            seen[d] = hit;
          }
        }
        const int score0 = far[0] - 2 * close[0], score1 = far[1] - 2 * close[1];
        if (far[0] >= 2 && far[1] >= 2 && close[0] + close[1] == 0) {
          w_.flags[i] |= kTwoSided;
        } else if (std::abs(score0 - score1) >= 2) {
          if (score1 > score0) w_.normal[i] = -w_.normal[i];
          w_.orient[i] = 1;
          w_.source[i] = Source::kVisibility;
          w_.confidence[i] = 0.5f * static_cast<float>(std::abs(score0 - score1));
        } else {
          continue;
        }
        // The open sides' sight lines, to carve once every point is oriented.
        for (std::size_t d = 0; d < dirs.size(); ++d) {
          if (seen[d] == kNone) continue;
          if ((w_.flags[i] & kTwoSided) || dirs[d].dot(w_.normal[i]) > 0.0f) my_hits.emplace_back(i, seen[d]);
        }
      }
      const std::size_t d = done.fetch_add(end - blocks[k].first) + (end - blocks[k].first);
      if (omp_get_thread_num() == 0) progress_(2, static_cast<double>(d) / static_cast<double>(n));
    });
    for (auto& h : hits) {
      budget_.charge(h.size() * sizeof(h[0]), "sight lines between surfaces");
      surface_hits_.insert(surface_hits_.end(), h.begin(), h.end());
    }
    std::sort(surface_hits_.begin(), surface_hits_.end());
  }

  // Most confident first, each undecided planar point takes the side of the neighbour on its sheet that reaches it
  // first (normals at least 45 deg apart do not pass it on: creases are where orientations go wrong).
  void propagate_orientation() {
    const std::size_t n = w_.size();
    using Item = std::pair<float, std::uint32_t>;
    std::priority_queue<Item> queue;
    for (std::uint32_t i = 0; i < n; ++i) {
      if (w_.is_signed(i)) queue.emplace(w_.confidence[i], i);
    }
    const float sheet = kSheet * vs_;
    while (!queue.empty()) {
      const auto [conf, i] = queue.top();
      queue.pop();
      if (conf < w_.confidence[i]) continue;
      const Vector3i& v = w_.voxel[i];
      for (int dz = -kRadius; dz <= kRadius; ++dz)
        for (int dy = -kRadius; dy <= kRadius; ++dy)
          for (int dx = -kRadius; dx <= kRadius; ++dx) {
            const Vector3i u = v + Vector3i(dx, dy, dz);
            const GridBlock* g = last_block(u);
            const std::uint32_t j = g ? g->find(local_of(u)) : kNone;
            if (j == kNone || j == i || w_.source[j] == Source::kTrajectory || w_.source[j] == Source::kVisibility)
              continue;
            if (!(w_.flags[j] & kPlanar) || (w_.flags[j] & kTwoSided)) continue;
            const float dot = w_.normal[i].dot(w_.normal[j]);
            if (std::abs(dot) < 0.7f || std::abs(w_.normal[i].dot(w_.anchor[j] - w_.anchor[i])) > sheet) continue;
            const float c = conf * std::abs(dot) * 0.95f;
            if (c <= w_.confidence[j]) continue;
            if (dot < 0.0f) w_.normal[j] = -w_.normal[j];
            w_.orient[j] = 1;
            w_.source[j] = Source::kPropagation;
            w_.confidence[j] = c;
            queue.emplace(c, j);
          }
    }
  }

  const GridBlock* last_block(const Vector3i& v) {
    const Vector3i b = block_of(v);
    if (b != cached_block_) {
      cached_block_ = b;
      cached_ = grid_.block(b);
    }
    return cached_;
  }

  void count_kinds() {
    for (std::size_t i = 0; i < w_.size(); ++i) {
      if (w_.flags[i] & kPlanar) ++report_.planar;
      if (w_.flags[i] & kTwoSided) ++report_.two_sided;
      if (!w_.is_signed(i)) ++report_.unsigned_points;
      switch (w_.source[i]) {
        case Source::kTrajectory:
          ++report_.oriented_by_trajectory;
          break;
        case Source::kVisibility:
          ++report_.oriented_by_visibility;
          break;
        case Source::kPropagation:
          ++report_.oriented_by_propagation;
          break;
        case Source::kUnknown:
          break;
      }
    }
    progress_(3, 0.0);
  }

  // ------------------------------------------------------------------------------------------------ 4. the band
  void make_box() {
    Vector3f lo = Vector3f::Constant(std::numeric_limits<float>::infinity()), hi = -lo;
    for (const Vector3f& p : w_.anchor) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    for (const auto& vp : w_.viewpoint) {
      for (std::uint32_t k : vp) {
        if (k == kNone) continue;
        lo = lo.cwiseMin(keyposes_.points()[k]);
        hi = hi.cwiseMax(keyposes_.points()[k]);
      }
    }
    const float border = trunc_ + 2.0f * vs_ + o_.margin;
    const Vector3f box_lo = lo.array() - border, box_hi = hi.array() + border;
    // Per cell: the band slot, the free mark, the fill's queue entry and mark, the map's coarse entry.
    budget_.charge(
        TsdfMap::box_cells(vs_, trunc_, box_lo, box_hi) * (3 * sizeof(std::uint32_t) + 2 + sizeof(std::int64_t)),
        "the cloud's box in blocks");
    map_ = TsdfMap::covering(vs_, trunc_, box_lo, box_hi);
    slot_.assign(map_.coarse_index().size(), kNone);
    free_ = std::make_unique<std::atomic<std::uint8_t>[]>(slot_.size());
    for (std::size_t c = 0; c < slot_.size(); ++c) free_[c].store(0, std::memory_order_relaxed);
  }

  std::uint32_t slot_of(const Vector3i& block, bool allocate) {
    const std::int64_t cell = map_.coarse_cell(block);
    if (cell < 0) return kNone;
    std::uint32_t& s = slot_[static_cast<std::size_t>(cell)];
    if (s == kNone && allocate) {
      budget_.charge(
          sizeof(FireBlock) + sizeof(BandBlock) + TsdfMap::kWordsPerBlock * sizeof(std::uint32_t) + sizeof(Vector3i),
          "blocks near the surface");
      s = static_cast<std::uint32_t>(fire_.size());
      fire_.emplace_back();
      band_block_.push_back(block);
    }
    return s;
  }

  // Nearest working point of every voxel within the truncation (Chebyshev layers; each voxel takes the nearest of
  // the points its neighbours in the previous layer carry, which is within a small fraction of a voxel of exact).
  // Then, within the blocks reached, the rest of the voxels (beyond the truncation: +-truncation, as the mesh builder
  // fills its band blocks). Layers hold (band block, local index) pairs.
  void brushfire() {
    const int layers = static_cast<int>(std::ceil(trunc_ / vs_));
    // A layer holds about as many voxels as both sides of the surfaces: a few per working point.
    budget_.charge(w_.size() * 6 * sizeof(std::uint64_t), "the brushfire's layers");
    std::vector<std::uint64_t> frontier, next;
    frontier.reserve(w_.size());
    for (std::uint32_t i = 0; i < w_.size(); ++i) {
      const Vector3i& v = w_.voxel[i];
      const std::uint32_t s = slot_of(block_of(v), true);
      fire_[s].nearest[static_cast<std::size_t>(local_of(v))] = i;
      frontier.push_back(std::uint64_t{s} << 9 | static_cast<std::uint64_t>(local_of(v)));
    }
    constexpr std::uint32_t kUnset = kNone - 1;
    for (int layer = 1; !frontier.empty(); ++layer) {
      const bool band = layer <= layers;
      const auto mark = static_cast<std::uint8_t>(std::min(layer, 255));
      next.clear();
      std::uint32_t cached = kNone;
      std::array<std::uint32_t, 27> around{};
      for (const std::uint64_t entry : frontier) {
        const auto s = static_cast<std::uint32_t>(entry >> 9);
        const int l = static_cast<int>(entry & 511);
        if (s != cached) {
          cached = s;
          around.fill(kUnset);
        }
        const std::uint32_t i = fire_[s].nearest[static_cast<std::size_t>(l)];
        const Vector3i lv(l & 7, (l >> 3) & 7, l >> 6);
        for (int k = 0; k < 27; ++k) {
          if (k == 13) continue;
          const Vector3i u = lv + Vector3i(k % 3 - 1, (k / 3) % 3 - 1, k / 9 - 1);
          const Vector3i offset(u.x() >> 3, u.y() >> 3, u.z() >> 3);
          const int c = (offset.x() + 1) + 3 * ((offset.y() + 1) + 3 * (offset.z() + 1));
          std::uint32_t& t = around[static_cast<std::size_t>(c)];
          if (t == kUnset) t = slot_of(band_block_[s] + offset, band);
          if (t == kNone) continue;
          FireBlock& f = fire_[t];
          const int ul = (u.x() & 7) + B * ((u.y() & 7) + B * (u.z() & 7));
          std::uint32_t& cur = f.nearest[static_cast<std::size_t>(ul)];
          if (cur == kNone) {
            cur = i;
            f.layer[static_cast<std::size_t>(ul)] = mark;
            next.push_back(std::uint64_t{t} << 9 | static_cast<std::uint64_t>(ul));
          } else if (band && f.layer[static_cast<std::size_t>(ul)] == mark && cur != i) {
            const Vector3f x =
                ((band_block_[t] * B).cast<float>() +
                 Vector3f(static_cast<float>(ul & 7), static_cast<float>((ul >> 3) & 7), static_cast<float>(ul >> 6))) *
                vs_;
            if ((x - w_.anchor[i]).squaredNorm() < (x - w_.anchor[cur]).squaredNorm()) cur = i;
          }
        }
      }
      frontier.swap(next);
      if (band) progress_(3, 0.8 * layer / layers);
    }
  }

  void signed_distances() {
    for (std::size_t s = 0; s < fire_.size(); ++s) band_.emplace_back();
    report_.band_blocks = fire_.size();
    const float foot = vs_, trunc = trunc_;
    parallel_blocks(fire_.size(), [&](std::size_t s) {
      const FireBlock& f = fire_[s];
      BandBlock& b = band_[s];
      const Neighbourhood nb(grid_, band_block_[s]);
      const Vector3i first = band_block_[s] * B;
      for (int l = 0; l < kVoxels; ++l) {
        const std::uint32_t i = f.nearest[static_cast<std::size_t>(l)];
        if (i == kNone) continue;
        const Vector3f x = (first + Vector3i(l % B, (l / B) % B, l / (B * B))).cast<float>() * vs_;
        const Vector3f d = x - w_.anchor[i];
        float value;
        bool unsure;
        if (w_.is_signed(i)) {
          const float dn = w_.normal[i].dot(d);
          const float beside = std::max(0.0f, (d - dn * w_.normal[i]).norm() - foot);
          value = std::copysign(std::sqrt(dn * dn + beside * beside), dn);
          // Beside the edge of a surface rather than in front of or behind it: the sign is a guess.
          unsure = beside > std::abs(dn);
        } else {
          value = std::max(0.0f, d.norm() - 0.5f * vs_);
          unsure = true;
        }
        if (unsure) {
          value = std::abs(value);
          // Near the crease of a room's corner or the edge of a floor, the oriented surfaces around agree on the side
          // (beyond the truncation the side matters less than the time: free space decides there).
          const int side = value < trunc ? vote(nb, x) : 0;
          if (side != 0) {
            value *= static_cast<float>(side);
            unsure = false;
          }
        }
        b.q[static_cast<std::size_t>(l)] = map_.quantize(std::clamp(value, -trunc, trunc));
        if (unsure) b.unsure[static_cast<std::size_t>(l >> 6)] |= std::uint64_t{1} << (l & 63);
      }
    });
    std::deque<FireBlock>().swap(fire_);
    progress_(3, 1.0);
  }

  // +1 or -1 if at least three signed points within kRadius of voxel centre x see it on the same side of their plane
  // (and not within half a voxel of it), else 0.
  int vote(const Neighbourhood& nb, const Vector3f& x) const {
    const Vector3i v = (x / vs_).array().round().cast<int>();
    int front = 0, behind = 0;
    for (int dz = -kRadius; dz <= kRadius; ++dz)
      for (int dy = -kRadius; dy <= kRadius; ++dy)
        for (int dx = -kRadius; dx <= kRadius; ++dx) {
          const std::uint32_t j = nb.find(v + Vector3i(dx, dy, dz));
          if (j == kNone || !w_.is_signed(j)) continue;
          const float dn = w_.normal[j].dot(x - w_.anchor[j]);
          if (std::abs(dn) < 0.5f * vs_) continue;
          (dn > 0.0f ? front : behind) += 1;
          if (front > 0 && behind > 0) return 0;
        }
    return front >= 3 ? 1 : behind >= 3 ? -1 : 0;
  }

  // --------------------------------------------------------------------------------------------- 5. free space
  void carve() {
    std::vector<SightLine> lines;
    if (!keyposes_.empty()) {
      for (std::uint32_t i = 0; i < w_.size(); ++i) {
        for (std::uint32_t k : w_.viewpoint[i]) {
          if (k != kNone) lines.push_back({keyposes_.points()[k], w_.anchor[i]});
        }
      }
    } else {
      for (const auto& [i, j] : surface_hits_) {
        // Only between surfaces facing each other (or sheets without a side).
        if (w_.is_signed(j) && w_.normal[j].dot(w_.anchor[i] - w_.anchor[j]) <= 0.0f) continue;
        lines.push_back({w_.anchor[i], w_.anchor[j]});
      }
      std::vector<std::pair<std::uint32_t, std::uint32_t>>().swap(surface_hits_);
    }
    budget_.charge(lines.size() * sizeof(SightLine), "sight lines");
    report_.sight_lines = lines.size();
    const float stop = 0.5f * vs_;
    std::atomic<std::size_t> done{0};
    const std::size_t batch = 4096;
    parallel_blocks((lines.size() + batch - 1) / batch, [&](std::size_t k) {
      const std::size_t end = std::min(lines.size(), (k + 1) * batch);
      for (std::size_t s = k * batch; s < end; ++s) {
        const Vector3f ray = lines[s].to - lines[s].from;
        const float length = ray.norm() - stop;
        if (!(length > 0.0f)) continue;
        const Vector3f dir = ray.normalized();
        walk_until(lines[s].from, dir, 0.0f, length, vs_, B, [&](const Vector3i& block, float t_in, float t_out) {
          const std::int64_t cell = map_.coarse_cell(block);
          if (cell < 0) return true;
          const std::uint32_t slot = slot_[static_cast<std::size_t>(cell)];
          if (slot == kNone) {
            free_[static_cast<std::size_t>(cell)].store(1, std::memory_order_relaxed);
            return true;
          }
          BandBlock& b = band_[slot];
          walk_until(lines[s].from, dir, t_in, t_out, vs_, 1, [&](const Vector3i& v, float, float) {
            if (block_of(v) != block) return true;
            const int l = local_of(v);
            std::atomic<std::uint8_t>& c = b.crossed[static_cast<std::size_t>(l)];
            std::uint8_t n = c.load(std::memory_order_relaxed);
            while (n < 255 &&
                   !c.compare_exchange_weak(n, static_cast<std::uint8_t>(n + 1), std::memory_order_relaxed)) {
            }
            return true;
          });
          return true;
        });
      }
      const std::size_t d = done.fetch_add(end - k * batch) + (end - k * batch);
      if (omp_get_thread_num() == 0)
        progress_(4, static_cast<double>(d) / static_cast<double>(std::max<std::size_t>(1, lines.size())));
    });
  }

  // Connected regions of unknown blocks away from surfaces, enclosed (not touching the box's border): free if the
  // surfaces and free blocks around them mostly face them with free space.
  void fill_enclosed() {
    const Vector3i dims = map_.dims_blocks();
    const std::int64_t cells = static_cast<std::int64_t>(slot_.size());
    const std::int64_t stride[3] = {1, dims.x(), static_cast<std::int64_t>(dims.x()) * dims.y()};
    std::vector<std::uint8_t> visited(slot_.size(), 0);
    std::vector<std::int64_t> component;
    for (std::int64_t seed = 0; seed < cells; ++seed) {
      const auto s = static_cast<std::size_t>(seed);
      if (visited[s] || slot_[s] != kNone || free_[s].load(std::memory_order_relaxed)) continue;
      component.clear();
      component.push_back(seed);
      visited[s] = 1;
      bool border = false;
      std::int64_t positive = 0, negative = 0;
      for (std::size_t next = 0; next < component.size(); ++next) {
        const std::int64_t cell = component[next];
        const Vector3i rel(static_cast<int>(cell % dims.x()), static_cast<int>((cell / dims.x()) % dims.y()),
                           static_cast<int>(cell / stride[2]));
        for (int axis = 0; axis < 3; ++axis) {
          for (int dir : {-1, 1}) {
            const int r = rel[axis] + dir;
            if (r < 0 || r >= dims[axis]) {
              border = true;
              continue;
            }
            const std::int64_t nbr = cell + dir * stride[axis];
            const auto ns = static_cast<std::size_t>(nbr);
            if (free_[ns].load(std::memory_order_relaxed)) {
              positive += B * B;
              continue;
            }
            if (slot_[ns] == kNone) {
              if (!visited[ns]) {
                visited[ns] = 1;
                component.push_back(nbr);
              }
              continue;
            }
            // The band block's voxel layer facing this block.
            const BandBlock& b = band_[slot_[ns]];
            const int layer = dir > 0 ? 0 : B - 1;
            for (int i = 0; i < B; ++i) {
              for (int j = 0; j < B; ++j) {
                Vector3i l;
                l[axis] = layer;
                l[(axis + 1) % 3] = i;
                l[(axis + 2) % 3] = j;
                const int li = l.x() + B * (l.y() + B * l.z());
                const std::int16_t q = b.q[static_cast<std::size_t>(li)];
                if (q == TsdfMap::kUnknownValue || (b.unsure[static_cast<std::size_t>(li >> 6)] >> (li & 63) & 1))
                  continue;
                positive += q > 0;
                negative += q < 0;
              }
            }
          }
        }
      }
      if (!border && positive > negative) {
        for (std::int64_t cell : component) free_[static_cast<std::size_t>(cell)].store(2, std::memory_order_relaxed);
      }
    }
  }

  TsdfMap assemble() {
    const float vs = vs_;
    const std::int16_t full = map_.quantize(trunc_);
    std::array<std::int16_t, kVoxels> values;
    for (std::size_t s = 0; s < band_.size(); ++s) {
      const BandBlock& b = band_[s];
      for (int l = 0; l < kVoxels; ++l) {
        const auto li = static_cast<std::size_t>(l);
        const int crossed = b.crossed[li].load(std::memory_order_relaxed);
        const bool freed = crossed > 0;
        const bool unsure = b.unsure[li >> 6] >> (l & 63) & 1;
        std::int16_t q = b.q[li];
        if (q == TsdfMap::kUnknownValue) {
          q = freed ? full : TsdfMap::kUnknownValue;
        } else if (unsure && !freed && map_.dequantize(q) > 0.5f * vs) {
          q = TsdfMap::kUnknownValue;
        } else if (q < 0 && crossed >= kMinCrossings && map_.dequantize(q) <= -2.0f * vs) {
          // Behind a surface seen from one side only, yet sight lines pass: the far side of something thin (a desk
          // top seen from below), free. Within two voxels of the surface its own sign stands.
          q = static_cast<std::int16_t>(-q);
        }
        values[li] = q;
      }
      map_.set_block(band_block_[s], values);
    }
    const Vector3i dims = map_.dims_blocks();
    for (std::size_t c = 0; c < slot_.size(); ++c) {
      if (slot_[c] != kNone || !free_[c].load(std::memory_order_relaxed)) continue;
      const auto cc = static_cast<std::int64_t>(c);
      map_.mark_block_free(map_.min_block() +
                           Vector3i(static_cast<int>(cc % dims.x()), static_cast<int>((cc / dims.x()) % dims.y()),
                                    static_cast<int>(cc / (static_cast<std::int64_t>(dims.x()) * dims.y()))));
    }
    std::deque<BandBlock>().swap(band_);
    map_.compact();
    report_.free_blocks = map_.stats().free_blocks;
    progress_(5, 0.5);
    return std::move(map_);
  }

  void count_surface(const TsdfMap& map) {
    std::uint64_t surface = 0;
#pragma omp parallel for reduction(+ : surface) schedule(static)
    for (std::int64_t i = 0; i < static_cast<std::int64_t>(w_.size()); ++i) {
      const TsdfMap::Sample s = map.trilinear(w_.anchor[static_cast<std::size_t>(i)]);
      if (s.known && std::abs(s.distance) <= vs_) surface += w_.count[static_cast<std::size_t>(i)];
    }
    report_.surface_points = surface;
    progress_(5, 1.0);
  }

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

}  // namespace

std::string describe(const CloudMapReport& r) {
  const auto percent = [](std::uint64_t part, std::uint64_t whole) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.1f %%",
                  whole ? 100.0 * static_cast<double>(part) / static_cast<double>(whole) : 0.0);
    return std::string(buf);
  };
  const auto n = [](std::uint64_t v) { return std::to_string(v); };
  std::string out = "build-map: cloud: " + n(r.input_points) + " points read; dropped " + n(r.non_finite) +
                    " not finite, " + n(r.out_of_range) + " out of range, " + n(r.isolated_points) + " isolated (" +
                    n(r.isolated_voxels) + " voxels); " + n(r.used_points) + " used, in " + n(r.voxels) + " voxels\n";
  out += "build-map: normals: " + n(r.planar) + " of the voxels planar, oriented " + n(r.oriented_by_trajectory) +
         " by the trajectory, " + n(r.oriented_by_visibility) + " by visibility, " + n(r.oriented_by_propagation) +
         " by propagation; " + n(r.two_sided) + " two-sided; " + n(r.unsigned_points) + " unsigned (distance only)\n";
  out += "build-map: surface: " + n(r.surface_points) + " of the used points (" +
         percent(r.surface_points, r.used_points) + ") within a voxel of the map's surface; " + n(r.band_blocks) +
         " blocks near it, " + n(r.free_blocks) + " free blocks from " + n(r.sight_lines) + " sight lines\n";
  char times[256];
  std::snprintf(times, sizeof(times),
                "build-map: seconds: %.1f reading and averaging, %.1f normals, %.1f orientation, %.1f distances, "
                "%.1f free space; %.1f in all\n",
                r.read_seconds, r.normal_seconds, r.orient_seconds, r.distance_seconds, r.free_seconds, r.seconds);
  return out + times;
}

TsdfMap build_map_from_cloud(PointSource& source, const CloudMapOptions& options, const ProgressFn& progress,
                             CloudMapReport* report) {
  validate(options);
  const auto started = std::chrono::steady_clock::now();
  CloudMapReport local;
  CloudMapReport& r = report ? *report : local;
  r = CloudMapReport{};
  Builder builder(options, progress, r);
  TsdfMap map = builder.run(source);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return map;
}

TsdfMap build_map_from_cloud(const std::vector<Eigen::Vector3f>& points, const CloudMapOptions& options,
                             const ProgressFn& progress, CloudMapReport* report) {
  VectorPointSource source(points);
  return build_map_from_cloud(source, options, progress, report);
}

}  // namespace tsdf_mcl
