// MapRaster: the map seen from above, column by column (the z range or slice, each column's obstacle, surface or
// free space, and its colour).
#include "tsdf_mcl/render/map_view.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numeric>

#include "map_colors.hpp"
#include "tsdf_mcl/core/checked_math.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {

using render::format_metres;
using render::height_color;
using render::kDeepInsideColor;
using render::kFreeColor;
using render::kInsideColor;
using render::kNearSurfaceColor;
using render::kSurfaceColor;
using render::kUnknownColor;

constexpr int kB = TsdfMap::kBlockSize;
// A sideways surface must span this many voxels of one column to count as an obstacle: single voxels are mostly
// noise on floors and the rims of horizontal surfaces.
constexpr int kMinObstacleVoxels = 2;
// Surfaces whose distance changes mostly vertically (normal within roughly 37 degrees of vertical: floors, ramps,
// ceilings) are not obstacles.
constexpr float kVerticalNormalCos2 = 0.64f;

int floor_div(int a, int b) {
  const int q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

std::int16_t word_half(std::uint32_t word, int l) {
  return static_cast<std::int16_t>((l & 1) ? (word >> 16) : (word & 0xFFFFu));
}

// A voxel's quantized distance near a block: most neighbours lie in the same block (`entry`, first voxel
// `block_voxel0`), the rest go through the coarse index.
std::int16_t quantized_near(const TsdfMap& map, const Eigen::Vector3i& v, std::uint32_t entry,
                            const Eigen::Vector3i& block_voxel0) {
  const Eigen::Vector3i l = v - block_voxel0;
  if ((l.array() >= 0).all() && (l.array() < kB).all()) {
    const int li = l.x() + kB * (l.y() + kB * l.z());
    return word_half(map.block_pool()[static_cast<std::size_t>(entry) * TsdfMap::kWordsPerBlock + li / 2], li);
  }
  return map.quantized(v);
}

// How much the distance changes along an axis (for the surface orientation): the larger one-sided difference to a
// known neighbour. A central difference would vanish in the middle of a wall one or two voxels thin, where the
// distance rises to both sides.
float variation(const TsdfMap& map, int q, const Eigen::Vector3i& v, const Eigen::Vector3i& axis, std::uint32_t entry,
                const Eigen::Vector3i& b0) {
  float change = 0.0f;
  for (const Eigen::Vector3i& n : {Eigen::Vector3i(v + axis), Eigen::Vector3i(v - axis)}) {
    const std::int16_t qn = quantized_near(map, n, entry, b0);
    if (qn != TsdfMap::kUnknownValue) change = std::max(change, static_cast<float>(std::abs(qn - q)));
  }
  return change;
}

}  // namespace

MapRaster::MapRaster(const TsdfMap& map, const MapRasterOptions& options) {
  if (map.empty()) throw Error("the map is empty");
  const float vs = map.voxel_size();
  voxel_size_ = vs;
  truncation_ = map.truncation();
  const Eigen::Vector3i dims = map.dims_blocks();
  const Eigen::Vector3i first = map.min_block() * kB;
  const Eigen::Vector3i last = (map.min_block() + dims) * kB - Eigen::Vector3i::Ones();
  first_column_ = first.head<2>();
  nx_ = dims.x() * kB;
  ny_ = dims.y() * kB;
  cells_.assign(static_cast<std::size_t>(nx_) * ny_, Cell::kUnknown);
  values_.assign(cells_.size(), std::numeric_limits<float>::quiet_NaN());
  const float map_z_lo = static_cast<float>(first.z()) * vs, map_z_hi = static_cast<float>(last.z()) * vs;
  char range[96];
  std::snprintf(range, sizeof(range), "%.2f .. %.2f m", static_cast<double>(map_z_lo), static_cast<double>(map_z_hi));

  const auto [k_lo, k_hi] = voxel_z_range(map, options, range);
  z_min_ = static_cast<float>(k_lo) * vs;
  z_max_ = static_cast<float>(k_hi) * vs;
  // Counted only up to kMinObstacleVoxels: whether a column is an obstacle is all that matters.
  std::vector<std::uint8_t> obstacle_voxels(slice_ ? 0 : cells_.size(), 0);
  rasterize(map, k_lo, k_hi, obstacle_voxels);
  if (!slice_) classify_obstacles(obstacle_voxels);
}

std::pair<int, int> MapRaster::voxel_z_range(const TsdfMap& map, const MapRasterOptions& options,
                                             const std::string& range) {
  const float vs = map.voxel_size();
  const Eigen::Vector3i first = map.min_block() * kB;
  const Eigen::Vector3i last = (map.min_block() + map.dims_blocks()) * kB - Eigen::Vector3i::Ones();
  int k_lo = 0, k_hi = 0;
  if (options.slice_z) {
    slice_ = true;
    if (options.z_min || options.z_max) throw Error("choose either a slice height or a z-range, not both");
    const float z = *options.slice_z;
    if (!std::isfinite(z)) throw Error("slice height is not finite");
    const int k = static_cast<int>(std::lround(z / vs));
    if (k < first.z() || k > last.z()) {
      throw Error("slice height " + format_metres(z) + " is outside the map (voxel centres at z " + range + ")");
    }
    k_lo = k_hi = k;
  } else {
    const float lo = options.z_min.value_or(-std::numeric_limits<float>::infinity());
    const float hi = options.z_max.value_or(std::numeric_limits<float>::infinity());
    if (std::isnan(lo) || std::isnan(hi) || !(lo <= hi)) throw Error("z-range is empty (z-min above z-max)");
    // A hair of tolerance: "--z_min 0.5" on a 5 cm grid should include the voxel centred at 0.5.
    const double eps = 1e-4;
    k_lo = std::isfinite(lo) ? std::max(first.z(), io::saturated_ceil(lo / vs - eps)) : first.z();
    k_hi = std::isfinite(hi) ? std::min(last.z(), io::saturated_floor(hi / vs + eps)) : last.z();
    if (k_lo > k_hi) {
      throw Error("z-range " + format_metres(lo) + " .. " + format_metres(hi) + " holds no voxel of the map (z " +
                  range + ")");
    }
  }
  return {k_lo, k_hi};
}

void MapRaster::rasterize(const TsdfMap& map, int k_lo, int k_hi, std::vector<std::uint8_t>& obstacle_voxels) {
  const Eigen::Vector3i dims = map.dims_blocks();
  const auto& coarse = map.coarse_index();
  const int bz_lo = floor_div(k_lo, kB) - map.min_block().z();
  const int bz_hi = floor_div(k_hi, kB) - map.min_block().z();
  for (int cz = bz_lo; cz <= bz_hi; ++cz) {
    const int block_k0 = (map.min_block().z() + cz) * kB;
    const int lz_lo = std::max(0, k_lo - block_k0), lz_hi = std::min(kB - 1, k_hi - block_k0);
    for (int cy = 0; cy < dims.y(); ++cy) {
      for (int cx = 0; cx < dims.x(); ++cx) {
        const std::uint32_t entry =
            coarse[static_cast<std::size_t>(cx) +
                   static_cast<std::size_t>(dims.x()) * (cy + static_cast<std::size_t>(dims.y()) * cz)];
        if (entry == TsdfMap::kUnknownBlock) continue;
        if (entry == TsdfMap::kFreeBlock) {
          fill_free_block(cx, cy);
        } else {
          rasterize_block(map, entry, Eigen::Vector3i(cx, cy, cz), lz_lo, lz_hi, obstacle_voxels);
        }
      }
    }
  }
}

void MapRaster::fill_free_block(int cx, int cy) {
  for (int ly = 0; ly < kB; ++ly) {
    for (int lx = 0; lx < kB; ++lx) {
      const std::size_t c = index(cx * kB + lx, cy * kB + ly);
      if (cells_[c] != Cell::kUnknown) continue;
      cells_[c] = Cell::kFree;
      if (slice_) values_[c] = truncation_;
    }
  }
}

void MapRaster::rasterize_block(const TsdfMap& map, std::uint32_t entry, const Eigen::Vector3i& block, int lz_lo,
                                int lz_hi, std::vector<std::uint8_t>& obstacle_voxels) {
  const float vs = map.voxel_size();
  const auto& pool = map.block_pool();
  const int q_surface = static_cast<int>(vs / truncation_ * TsdfMap::kQuantMax);
  const int cx = block.x(), cy = block.y();
  const Eigen::Vector3i b0 = (map.min_block() + block) * kB;
  for (int lz = lz_lo; lz <= lz_hi; ++lz) {
    for (int ly = 0; ly < kB; ++ly) {
      for (int lx = 0; lx < kB; ++lx) {
        const int li = lx + kB * (ly + kB * lz);
        const std::int16_t q = word_half(pool[static_cast<std::size_t>(entry) * TsdfMap::kWordsPerBlock + li / 2], li);
        if (q == TsdfMap::kUnknownValue) continue;
        const std::size_t c = index(cx * kB + lx, cy * kB + ly);
        if (slice_) {
          const float d = map.dequantize(q);
          values_[c] = d;
          cells_[c] = q >= q_surface ? Cell::kFree : q <= -q_surface ? Cell::kInside : Cell::kSurface;
          continue;
        }
        if (cells_[c] == Cell::kUnknown) cells_[c] = Cell::kFree;
        if (std::abs(static_cast<int>(q)) >= q_surface) continue;
        const Eigen::Vector3i v = b0 + Eigen::Vector3i(lx, ly, lz);
        const float gx = variation(map, q, v, Eigen::Vector3i::UnitX(), entry, b0);
        const float gy = variation(map, q, v, Eigen::Vector3i::UnitY(), entry, b0);
        const float gz = variation(map, q, v, Eigen::Vector3i::UnitZ(), entry, b0);
        const float g2 = gx * gx + gy * gy + gz * gz;
        if (!(g2 > 0.0f) || gz * gz >= kVerticalNormalCos2 * g2) continue;
        if (obstacle_voxels[c] < kMinObstacleVoxels) ++obstacle_voxels[c];
        const float z = static_cast<float>(v.z()) * vs;
        if (!(values_[c] >= z)) values_[c] = z;
      }
    }
  }
}

void MapRaster::classify_obstacles(const std::vector<std::uint8_t>& obstacle_voxels) {
  obstacle_min_ = std::numeric_limits<float>::infinity();
  obstacle_max_ = -std::numeric_limits<float>::infinity();
  for (std::size_t c = 0; c < cells_.size(); ++c) {
    if (obstacle_voxels[c] >= kMinObstacleVoxels) {
      cells_[c] = Cell::kObstacle;
      obstacle_min_ = std::min(obstacle_min_, values_[c]);
      obstacle_max_ = std::max(obstacle_max_, values_[c]);
    } else {
      values_[c] = std::numeric_limits<float>::quiet_NaN();
    }
  }
  if (obstacle_min_ > obstacle_max_) {
    obstacle_min_ = z_min_;
    obstacle_max_ = z_max_;
  }
}

std::optional<Eigen::Vector2i> MapRaster::column_at(const Eigen::Vector2d& world) const {
  const int i = io::saturated_floor(world.x() / voxel_size_ + 0.5) - first_column_.x();
  const int j = io::saturated_floor(world.y() / voxel_size_ + 0.5) - first_column_.y();
  if (i < 0 || j < 0 || i >= nx_ || j >= ny_) return std::nullopt;
  return Eigen::Vector2i(i, j);
}

Eigen::Vector2d MapRaster::column_center(int i, int j) const {
  return Eigen::Vector2d(first_column_.x() + i, first_column_.y() + j) * static_cast<double>(voxel_size_);
}

std::optional<Eigen::AlignedBox2d> MapRaster::known_bounds() const {
  int i0 = nx_, j0 = ny_, i1 = -1, j1 = -1;
  for (int j = 0; j < ny_; ++j) {
    for (int i = 0; i < nx_; ++i) {
      if (cells_[index(i, j)] == Cell::kUnknown) continue;
      i0 = std::min(i0, i);
      i1 = std::max(i1, i);
      j0 = std::min(j0, j);
      j1 = std::max(j1, j);
    }
  }
  if (i1 < 0) return std::nullopt;
  const Eigen::Vector2d half = Eigen::Vector2d::Constant(voxel_size_ / 2.0);
  return Eigen::AlignedBox2d(column_center(i0, j0) - half, column_center(i1, j1) + half);
}

Rgb MapRaster::color(int i, int j) const {
  const float v = value(i, j);
  switch (cell(i, j)) {
    case Cell::kUnknown:
      return kUnknownColor;
    case Cell::kFree:
      // Slices tint the truncation band, which shows where the map's distances still carry information.
      return slice_ ? mix(kNearSurfaceColor, kFreeColor, v / truncation_) : kFreeColor;
    case Cell::kObstacle: {
      const float span = obstacle_max_ - obstacle_min_;
      return height_color(span > 0.0f ? (v - obstacle_min_) / span : 0.5f);
    }
    case Cell::kSurface:
      return kSurfaceColor;
    case Cell::kInside:
      return mix(kInsideColor, kDeepInsideColor, -v / truncation_);
  }
  return kUnknownColor;
}

}  // namespace tsdf_mcl
