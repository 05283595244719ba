// TSDF integration of registered scans.
//
// Every ray (sensor origin -> point) is walked through the grid (Amanatides & Woo). A voxel's observation is the
// projective signed distance sdf = range - (centre - origin).u: inside the band (|sdf| <= truncation) it updates a
// weighted running average, kept as sums of w*sdf and w so that the order of the updates does not matter; in front
// of the band it is a free-space observation (+truncation, weight 1); behind the band nothing is learned.
// Behind the surface the weight falls linearly from 1 at -voxel to 0 at -truncation: what lies behind a surface
// is the least certain part of a ray (thin walls, grazing angles), so it should not outvote views from the other
// side.
//
// Two passes over the scans: the band first, so that the set of blocks near surfaces ("band blocks") is final;
// then free-space carving. Carving walks each ray block by block and descends to voxels only inside band blocks;
// a block without any band voxel that a ray crosses becomes a free block as a whole. That is free-space carving at
// block resolution away from surfaces: it costs an eighth of the steps, and it fills the gaps that diverging rays
// leave between them far from the sensor (no surface was seen there, or the block would be a band block).
// Except at the edge of what the scans saw: a crossed block beside a block no ray reached (a room the mapping run
// saw only through its door, below a floor seen from above) may hold a surface no ray met -- the floor of that room
// under rays that passed just above it. Calling all of it free would make the map claim there is nothing where it
// never looked. A third pass carves such frontier blocks voxel by voxel: what no ray crossed stays unknown.
//
// Projective distances overestimate where rays graze a surface: a voxel 5 cm above a floor seen at 7 degrees from
// afar lies 0.4 m before the hit along the ray, so it reads +truncation ("nothing near") although the floor is 5 cm
// away. A robot later standing on that floor, its points a few cm off it, would find them contradicting the map.
// A signed distance changes by at most the distance moved (it is 1-Lipschitz), so the free side is tightened:
// d(v) <= d(n) + |v - n| over the 26 neighbours, repeated until nothing changes (at most truncation / voxel sweeps).
//
// Parallelism without locks or atomics: space is cut into slabs of kSlabBlocks blocks across the box's longest
// axis, dealt out to the threads in turn. Each thread walks only the parts of every ray inside its own slabs and
// writes only there. Rays are cut at the same slab faces whatever the thread count, so the map does not depend on it.
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <exception>
#include <limits>
#include <utility>
#include <vector>

#include "block_grid.hpp"
#include "build_budget.hpp"
#include "grid_walk.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"

namespace tsdf_mcl {
namespace {

using Eigen::Vector3f;
using Eigen::Vector3i;
using grid::walk;

constexpr std::uint32_t kNoBlock = 0xFFFFFFFFu;
constexpr std::uint32_t kCarvedBlock = 0xFFFFFFFEu;  // crossed by rays, no band voxel: free as a whole
// Wide enough that a slab holds several steps of a block walk, narrow enough to balance a few dozen threads.
constexpr int kSlabBlocks = 4;

// Σ w·sdf and Σ w side by side: an update touches one cache line.
struct VoxelSums {
  float wd = 0.0f;
  float w = 0.0f;
};
using BandBlock = std::array<VoxelSums, kVoxels>;

// Points of one scan in the world frame, range-filtered.
struct WorldScan {
  Vector3f origin = Vector3f::Zero();
  std::vector<Vector3f> points;
};

WorldScan load_world_scan(const Dataset& dataset, std::size_t index, const ScanMapOptions& options) {
  const PointCloud cloud = dataset.load_scan(index);
  const Pose& pose = dataset.pose(index);
  const Eigen::Matrix3f r = pose.linear().cast<float>();
  WorldScan scan;
  scan.origin = pose.translation().cast<float>();
  scan.points.reserve(cloud.size());
  for (const Vector3f& p : cloud.points) {
    const float range = p.norm();
    if (!(range > 0.0f && range >= options.min_range && range <= options.max_range)) continue;
    scan.points.push_back(r * p + scan.origin);
  }
  return scan;
}

// The accumulator: a dense index over the observed box in blocks, and one pool of band blocks per owner.
class Accumulator {
 public:
  Accumulator(const TsdfMap& box, int owners, BuildBudget& budget)
      : budget_(budget),
        voxel_(box.voxel_size()),
        truncation_(box.truncation()),
        min_block_(box.min_block()),
        dims_(box.dims_blocks()),
        owners_(owners),
        slot_(box.coarse_index().size(), kNoBlock),
        frontier_(box.coarse_index().size(), 0),
        band_(static_cast<std::size_t>(owners)) {
    dims_.maxCoeff(&slab_axis_);
    slab_count_ = (dims_[slab_axis_] + kSlabBlocks - 1) / kSlabBlocks;
  }

  // One thread's view. It caches the block of the previous voxel: consecutive voxels of a ray mostly share one.
  class Writer {
   public:
    // Thread `thread` of a team of `team` serves the owners o with o % team == thread: the runtime may grant
    // fewer threads than the accumulator was made for, and every owner must still be served.
    Writer(Accumulator& acc, int thread, int team) : acc_(acc), thread_(thread), team_(team) {}

    // The band observations of the ray origin -> origin + range * u.
    void band(const Vector3f& origin, const Vector3f& u, float range) {
      const float trunc = acc_.truncation_, voxel = acc_.voxel_;
      owned_parts(origin, u, std::max(0.0f, range - trunc - slack()), range + trunc + slack(), [&](float ta, float tb) {
        walk(origin, u, ta, tb, voxel, 1, [&](const Vector3i& v, float, float) {
          const float sdf = range - (v.cast<float>() * voxel - origin).dot(u);
          if (sdf > trunc || sdf < -trunc || !select(block_of(v))) return;
          const float weight = sdf >= -voxel ? 1.0f : (trunc + sdf) / (trunc - voxel);
          if (weight <= 0.0f) return;
          std::uint32_t& slot = acc_.slot_[static_cast<std::size_t>(cell_)];
          auto& pool = acc_.band_[static_cast<std::size_t>(owner_)];
          if (slot == kNoBlock) {
            // The block's sums now, its pool block in the map later.
            acc_.budget_.charge(sizeof(BandBlock) + TsdfMap::kWordsPerBlock * sizeof(std::uint32_t),
                                "blocks near surfaces");
            slot = static_cast<std::uint32_t>(pool.size());
            pool.emplace_back();
          }
          VoxelSums& sums = pool[slot][local(v)];
          sums.wd += weight * sdf;
          sums.w += weight;
        });
      });
    }

    // The free space of the same ray in front of its band: block by block, voxel by voxel inside band blocks.
    // frontier_pass: voxel by voxel inside the frontier blocks only (mark_frontier), nothing else.
    void carve(const Vector3f& origin, const Vector3f& u, float range, bool frontier_pass) {
      const float trunc = acc_.truncation_, voxel = acc_.voxel_;
      if (range <= trunc) return;
      owned_parts(origin, u, 0.0f, range - trunc + slack(), [&](float ta, float tb) {
        walk(origin, u, ta, tb, voxel, B, [&](const Vector3i& block, float t_in, float t_out) {
          if (!select(block)) return;
          const auto cell = static_cast<std::size_t>(cell_);
          if (frontier_pass != (acc_.frontier_[cell] != 0)) return;
          std::uint32_t& slot = acc_.slot_[cell];
          if (slot == kNoBlock || slot == kCarvedBlock) {
            slot = kCarvedBlock;
            return;
          }
          BandBlock& b = acc_.band_[static_cast<std::size_t>(owner_)][slot];
          walk(origin, u, t_in, t_out, voxel, 1, [&](const Vector3i& v, float, float) {
            // Float rounding at the block's faces may start or end the walk in a neighbour's voxel.
            if (block_of(v) != block || range - (v.cast<float>() * voxel - origin).dot(u) <= trunc) return;
            VoxelSums& sums = b[local(v)];
            sums.wd += trunc;
            sums.w += 1.0f;
          });
        });
      });
    }

   private:
    // Calls part(ta, tb) for each piece of the segment t in [t0, t1] that crosses a slab this thread serves,
    // with slab_ set to that slab.
    template <typename Part>
    void owned_parts(const Vector3f& origin, const Vector3f& u, float t0, float t1, Part&& part) {
      const int a = acc_.slab_axis_;
      const float size = acc_.voxel_ * static_cast<float>(B * kSlabBlocks);
      const float base = (static_cast<float>(acc_.min_block_[a] * B) - 0.5f) * acc_.voxel_;  // face of slab 0
      auto slab_at = [&](float t) { return static_cast<int>(std::floor((origin[a] + t * u[a] - base) / size)); };
      const int s0 = slab_at(t0), s1 = slab_at(t1);
      const int first = std::max(0, std::min(s0, s1)), last = std::min(acc_.slab_count_ - 1, std::max(s0, s1));
      for (int s = first; s <= last; ++s) {
        if ((s % acc_.owners_) % team_ != thread_) continue;
        float ta = t0, tb = t1;
        if (u[a] != 0.0f) {
          const float face0 = (base + static_cast<float>(s) * size - origin[a]) / u[a];
          const float face1 = (base + static_cast<float>(s + 1) * size - origin[a]) / u[a];
          ta = std::max(t0, std::min(face0, face1));
          tb = std::min(t1, std::max(face0, face1));
        }
        if (!(ta < tb)) continue;
        slab_ = s;
        owner_ = s % acc_.owners_;
        block_ = Vector3i::Constant(std::numeric_limits<int>::min());
        part(ta, tb);
      }
    }

    // A ray touches a voxel only within half a voxel diagonal of the projection of the voxel's centre.
    float slack() const { return 0.5f * std::sqrt(3.0f) * acc_.voxel_; }
    static Vector3i block_of(const Vector3i& v) { return TsdfMap::block_of(v); }
    static std::size_t local(const Vector3i& v) { return static_cast<std::size_t>(TsdfMap::local_index(v)); }

    // True if the block is inside the box and in the current slab (a walk may round into the next one); sets cell_.
    bool select(const Vector3i& block) {
      if (block != block_) {
        block_ = block;
        const Vector3i c = block - acc_.min_block_;
        inside_ = (c.array() >= 0).all() && (c.array() < acc_.dims_.array()).all() &&
                  c[acc_.slab_axis_] / kSlabBlocks == slab_;
        if (inside_) {
          cell_ = c.x() + static_cast<std::int64_t>(acc_.dims_.x()) *
                              (c.y() + static_cast<std::int64_t>(acc_.dims_.y()) * c.z());
        }
      }
      return inside_;
    }

    Accumulator& acc_;
    int thread_, team_;
    int slab_ = -1, owner_ = 0;
    Vector3i block_ = Vector3i::Constant(std::numeric_limits<int>::min());
    std::int64_t cell_ = -1;
    bool inside_ = false;
  };

  // After the carving pass: every carved block with a face neighbour no ray reached (or outside the box) becomes
  // a frontier block, held voxel by voxel (all unknown until the frontier pass carves it). Returns how many.
  std::size_t mark_frontier() {
    std::vector<std::size_t> frontier;
    for (std::size_t cell = 0; cell < slot_.size(); ++cell) {
      if (slot_[cell] != kCarvedBlock) continue;
      const Vector3i c = cell_coordinates(cell);
      bool beside_unknown = false;
      for (int axis = 0; axis < 3 && !beside_unknown; ++axis) {
        for (int side : {-1, 1}) {
          Vector3i n = c;
          n[axis] += side;
          if (n[axis] < 0 || n[axis] >= dims_[axis] || slot_[cell_index(n)] == kNoBlock) beside_unknown = true;
        }
      }
      if (beside_unknown) frontier.push_back(cell);
    }
    for (std::size_t cell : frontier) {
      budget_.charge(sizeof(BandBlock) + TsdfMap::kWordsPerBlock * sizeof(std::uint32_t), "blocks at the frontier");
      auto& pool = band_[static_cast<std::size_t>((cell_coordinates(cell)[slab_axis_] / kSlabBlocks) % owners_)];
      slot_[cell] = static_cast<std::uint32_t>(pool.size());
      pool.emplace_back();
      frontier_[cell] = 1;
    }
    return frontier.size();
  }

  TsdfMap to_map() {
    // The band blocks' distances (NaN: unknown), tightened on the free side (see the top of this file).
    std::vector<std::size_t> cells;  // band block k lies in cell cells[k]
    std::vector<std::int64_t> band_of_cell(slot_.size(), -1);
    for (std::size_t cell = 0; cell < slot_.size(); ++cell) {
      if (slot_[cell] == kNoBlock || slot_[cell] == kCarvedBlock) continue;
      band_of_cell[cell] = static_cast<std::int64_t>(cells.size());
      cells.push_back(cell);
    }
    using Distances = std::array<float, kVoxels>;
    budget_.charge(2 * cells.size() * sizeof(Distances), "distances of blocks near surfaces");
    std::vector<Distances> distances(cells.size());
    for (std::size_t k = 0; k < cells.size(); ++k) {
      const BandBlock& b = band_block(cells[k]);
      for (std::size_t l = 0; l < kVoxels; ++l) {
        distances[k][l] = b[l].w > 0.0f ? b[l].wd / b[l].w : std::numeric_limits<float>::quiet_NaN();
      }
    }
    tighten_free_side(cells, band_of_cell, distances);

    TsdfMap map(voxel_, truncation_, min_block_, dims_);
    std::array<std::int16_t, kVoxels> values{};
    for (std::size_t cell = 0; cell < slot_.size(); ++cell) {
      if (slot_[cell] == kCarvedBlock) map.mark_block_free(min_block_ + cell_coordinates(cell));
    }
    for (std::size_t k = 0; k < cells.size(); ++k) {
      for (std::size_t l = 0; l < kVoxels; ++l) {
        const float d = distances[k][l];
        values[l] = std::isnan(d) ? TsdfMap::kUnknownValue : map.quantize(d);
      }
      map.set_block(min_block_ + cell_coordinates(cells[k]), values);
    }
    return map;
  }

 private:
  Vector3i cell_coordinates(std::size_t cell) const {
    const auto c = static_cast<std::int64_t>(cell);
    return {static_cast<int>(c % dims_.x()), static_cast<int>((c / dims_.x()) % dims_.y()),
            static_cast<int>(c / (static_cast<std::int64_t>(dims_.x()) * dims_.y()))};
  }
  std::size_t cell_index(const Vector3i& c) const {
    return static_cast<std::size_t>(c.x() + static_cast<std::int64_t>(dims_.x()) *
                                                (c.y() + static_cast<std::int64_t>(dims_.y()) * c.z()));
  }
  const BandBlock& band_block(std::size_t cell) const {
    return band_[static_cast<std::size_t>((cell_coordinates(cell)[slab_axis_] / kSlabBlocks) % owners_)][slot_[cell]];
  }

  // d(v) = min(d(v), d(n) + |v - n|) for every known voxel v on the free side (d > 0) and its known free-side
  // neighbours n (d >= 0; free blocks count as +truncation and cannot lower anything), in Jacobi sweeps (each reads the
  // previous one's values: the result does not depend on the thread count) until no value changes by more than a
  // thousandth of a voxel. A change spreads one voxel per sweep and stops within the truncation.
  template <typename Distances>
  void tighten_free_side(const std::vector<std::size_t>& cells, const std::vector<std::int64_t>& band_of_cell,
                         std::vector<Distances>& distances) const {
    constexpr int P = B + 2;  // a block with a one-voxel rim from its neighbours
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::vector<Distances> next(distances.size());
    const int sweeps = static_cast<int>(std::ceil(truncation_ / voxel_)) + 1;
    for (int sweep = 0; sweep < sweeps; ++sweep) {
      bool changed = false;
#pragma omp parallel for schedule(dynamic, 16) reduction(|| : changed)
      for (std::ptrdiff_t kk = 0; kk < static_cast<std::ptrdiff_t>(cells.size()); ++kk) {
        const auto k = static_cast<std::size_t>(kk);
        const Vector3i c = cell_coordinates(cells[k]);
        std::array<float, P * P * P> rim;
        for (int z = 0; z < P; ++z) {
          for (int y = 0; y < P; ++y) {
            for (int x = 0; x < P; ++x) {
              const Vector3i v(x - 1, y - 1, z - 1);  // voxel relative to the block's first one
              const Vector3i offset(v.x() < 0 ? -1 : v.x() >= B, v.y() < 0 ? -1 : v.y() >= B,
                                    v.z() < 0 ? -1 : v.z() >= B);
              const Vector3i n = c + offset;
              float value = nan;
              if ((n.array() >= 0).all() && (n.array() < dims_.array()).all()) {
                const std::size_t cell = cell_index(n);
                const Vector3i l = v - B * offset;
                if (band_of_cell[cell] >= 0) {
                  value = distances[static_cast<std::size_t>(band_of_cell[cell])]
                                   [static_cast<std::size_t>(l.x() + B * (l.y() + B * l.z()))];
                } else if (slot_[cell] == kCarvedBlock) {
                  value = truncation_;
                }
              }
              rim[static_cast<std::size_t>(x + P * (y + P * z))] = value;
            }
          }
        }
        for (int z = 0; z < B; ++z) {
          for (int y = 0; y < B; ++y) {
            for (int x = 0; x < B; ++x) {
              const std::size_t l = static_cast<std::size_t>(x + B * (y + B * z));
              float d = distances[k][l];
              if (d > 0.0f) {
                const float before = d;
                for (int dz = -1; dz <= 1; ++dz) {
                  for (int dy = -1; dy <= 1; ++dy) {
                    for (int dx = -1; dx <= 1; ++dx) {
                      const float n =
                          rim[static_cast<std::size_t>((x + 1 + dx) + P * ((y + 1 + dy) + P * (z + 1 + dz)))];
                      const int steps = dx * dx + dy * dy + dz * dz;
                      // Free-side neighbours only: a negative one is behind the surface, and pulling a free voxel
                      // below zero would move the surface.
                      if (steps == 0 || !(n >= 0.0f)) continue;
                      d = std::min(d, n + voxel_ * std::sqrt(static_cast<float>(steps)));
                    }
                  }
                }
                if (before - d > 1e-3f * voxel_) changed = true;
              }
              next[k][l] = d;
            }
          }
        }
      }
      distances.swap(next);
      if (!changed) break;
    }
  }

  BuildBudget& budget_;
  float voxel_, truncation_;
  Vector3i min_block_, dims_;
  int owners_;  // slab s belongs to owner s % owners_
  int slab_axis_ = 0, slab_count_ = 0;
  std::vector<std::uint32_t> slot_;          // kNoBlock, kCarvedBlock or a band block number in the owner's pool
  std::vector<std::uint8_t> frontier_;       // 1: a frontier block (mark_frontier), carved voxel by voxel
  std::vector<std::deque<BandBlock>> band_;  // deques: blocks never move once allocated
};

void validate(const Dataset& dataset, const std::vector<std::size_t>& scans, const ScanMapOptions& o) {
  if (!(o.voxel_size > 0.0f) || !std::isfinite(o.voxel_size)) {
    throw Error("voxel size must be positive, got " + std::to_string(o.voxel_size));
  }
  if (!(o.truncation >= o.voxel_size) || !std::isfinite(o.truncation)) {
    throw Error("truncation (" + std::to_string(o.truncation) + " m) must be at least the voxel size (" +
                std::to_string(o.voxel_size) + " m)");
  }
  if (!(o.min_range >= 0.0f) || !(o.max_range > o.min_range) || !std::isfinite(o.max_range)) {
    throw Error("range limits must satisfy 0 <= min_range < max_range (finite)");
  }
  if (!(o.margin >= 0.0f) || !std::isfinite(o.margin)) throw Error("margin must not be negative");
  if (!dataset.has_poses())
    throw Error("dataset " + dataset.dir().string() + " has no poses.txt (needed to place the scans)");
  if (scans.empty()) throw Error("no scans selected for the map");
  for (std::size_t i : scans) {
    if (i >= dataset.size()) {
      throw Error("scan " + std::to_string(i) + " selected, but dataset " + dataset.dir().string() + " has " +
                  std::to_string(dataset.size()) + " scans");
    }
  }
}

// The build's progress: four steps per scan (the box, the band, free space, the frontier), the last at the end.
struct StepProgress {
  const ProgressFn& progress;
  std::size_t steps;
  std::size_t done = 0;

  void step() {
    ++done;
    if (progress) progress(done, steps);
  }
};

// Pass 0: the observed box (origins and points grown by the band and a voxel of walking slack).
std::pair<Vector3f, Vector3f> observed_box(const Dataset& dataset, const std::vector<std::size_t>& scans,
                                           const ScanMapOptions& options, StepProgress& progress) {
  Vector3f lo = Vector3f::Constant(std::numeric_limits<float>::infinity());
  Vector3f hi = -lo;
  std::size_t points = 0;
  for (std::size_t i : scans) {
    const WorldScan scan = load_world_scan(dataset, i, options);
    lo = lo.cwiseMin(scan.origin);
    hi = hi.cwiseMax(scan.origin);
    for (const Vector3f& p : scan.points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    points += scan.points.size();
    progress.step();
  }
  if (points == 0) {
    throw Error("no scan point lies within the range limits [" + std::to_string(options.min_range) + ", " +
                std::to_string(options.max_range) + "] m");
  }
  const float border = options.truncation + options.voxel_size + options.margin;
  return {lo.array() - border, hi.array() + border};
}

// Pass 1: the truncation band around every point. Pass 2: free space in front of the band. Pass 3: the frontier
// blocks' free space, voxel by voxel (after all of pass 2: which blocks are frontier depends on every thread's).
// Within passes 1 and 2 a thread's carving depends only on the band blocks it owns itself, so the threads never
// wait for one another: each loads the scans on its own (cheap next to the integration) and runs at its own pace.
enum class Pass { kBand, kCarve, kFrontier };

void integrate(Accumulator& acc, int threads, std::initializer_list<Pass> passes, const Dataset& dataset,
               const std::vector<std::size_t>& scans, const ScanMapOptions& options, StepProgress& progress) {
  std::exception_ptr failure;
#pragma omp parallel num_threads(threads)
  {
    const int thread = omp_get_thread_num();
    Accumulator::Writer writer(acc, thread, omp_get_num_threads());
    try {
      for (const Pass pass : passes) {
        for (std::size_t i : scans) {
          const WorldScan scan = load_world_scan(dataset, i, options);
          for (const Vector3f& p : scan.points) {
            const Vector3f ray = p - scan.origin;
            const float range = ray.norm();
            if (pass == Pass::kBand) {
              writer.band(scan.origin, ray / range, range);
            } else {
              writer.carve(scan.origin, ray / range, range, pass == Pass::kFrontier);
            }
          }
          // Thread 0 is the calling thread: the callback runs where the caller expects it.
          if (thread == 0 && progress.done + 1 < progress.steps) progress.step();
        }
      }
    } catch (...) {
#pragma omp critical(scan_integration_failure)
      if (!failure) failure = std::current_exception();
    }
  }
  if (failure) std::rethrow_exception(failure);
}

}  // namespace

TsdfMap build_map_from_scans(const Dataset& dataset, const std::vector<std::size_t>& scans,
                             const ScanMapOptions& options, const ProgressFn& progress) {
  validate(dataset, scans, options);
  const float vs = options.voxel_size;
  const float trunc = options.truncation;
  StepProgress steps{progress, 4 * scans.size()};

  const auto [box_lo, box_hi] = observed_box(dataset, scans, options, steps);
  BuildBudget budget(options.max_memory_bytes);
  // Per cell of the box: the accumulator's slot, the box's and the result's coarse index entries.
  budget.charge(TsdfMap::box_cells(vs, trunc, box_lo, box_hi) * (3 * sizeof(std::uint32_t) + 1),
                "the observed box in blocks");
  const TsdfMap box = TsdfMap::covering(vs, trunc, box_lo, box_hi);
  const int threads = std::max(1, omp_get_max_threads());
  Accumulator acc(box, threads, budget);

  integrate(acc, threads, {Pass::kBand, Pass::kCarve}, dataset, scans, options, steps);
  if (acc.mark_frontier() > 0) integrate(acc, threads, {Pass::kFrontier}, dataset, scans, options, steps);
  steps.done = steps.steps - 1;  // the last step: however many scans the frontier pass walked
  steps.step();

  TsdfMap map = acc.to_map();
  map.compact();
  return map;
}

}  // namespace tsdf_mcl
