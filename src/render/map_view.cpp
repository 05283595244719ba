#include "tsdf_mcl/render/map_view.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <numeric>

#include "tsdf_mcl/core/checked_math.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {

constexpr int kB = TsdfMap::kBlockSize;
// A sideways surface must span this many voxels of one column to count as an obstacle: single voxels are mostly
// noise on floors and the rims of horizontal surfaces.
constexpr int kMinObstacleVoxels = 2;
// Surfaces whose distance changes mostly vertically (normal within roughly 37 degrees of vertical: floors, ramps,
// ceilings) are not obstacles.
constexpr float kVerticalNormalCos2 = 0.64f;

constexpr Rgb kUnknownColor = rgb_hex(0xbdbdbd);
constexpr Rgb kFreeColor = colors::kWhite;
constexpr Rgb kNearSurfaceColor = rgb_hex(0xc6dbef);
constexpr Rgb kSurfaceColor = rgb_hex(0x252525);
constexpr Rgb kInsideColor = rgb_hex(0xd6a5a5);
constexpr Rgb kDeepInsideColor = rgb_hex(0x8c4a4a);
constexpr Rgb kWeakParticle = rgb_hex(0xfcbba1);

int floor_div(int a, int b) {
  const int q = a / b;
  return (a % b != 0 && ((a < 0) != (b < 0))) ? q - 1 : q;
}

std::int16_t word_half(std::uint32_t word, int l) {
  return static_cast<std::int16_t>((l & 1) ? (word >> 16) : (word & 0xFFFFu));
}

// Viridis reversed, so that tall structure (walls) is dark and stands out like the walls of a floor plan while low
// clutter is light; without viridis' brightest tenth, which would vanish on white free space.
Rgb height_color(float t) { return viridis(0.9f * (1.0f - t)); }

// Particle colour and opacity by weight relative to the heaviest, on a log scale over three decades: the weights of
// an unconverged filter span many orders of magnitude, and a linear scale would show all but a few as zero.
float weight_level(float weight, float max_weight) {
  if (!(weight > 0.0f) || !(max_weight > 0.0f)) return 0.0f;
  return std::clamp(1.0f + std::log10(weight / max_weight) / 3.0f, 0.0f, 1.0f);
}

Rgb particle_weight_color(Rgb strong, float level) { return mix(kWeakParticle, strong, level); }

std::string format_metres(float v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f m", static_cast<double>(v));
  return text;
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

namespace {

// Which column wins a pixel that covers several (views coarser than the map): thin walls must not disappear
// between samples, so obstacles and surfaces beat free space, and anything known beats unknown.
int priority(MapRaster::Cell cell) {
  switch (cell) {
    case MapRaster::Cell::kUnknown:
      return 0;
    case MapRaster::Cell::kFree:
      return 1;
    case MapRaster::Cell::kInside:
      return 2;
    case MapRaster::Cell::kSurface:
    case MapRaster::Cell::kObstacle:
      return 3;
  }
  return 0;
}

// Column index range [first, last] under each pixel along one axis; first > last where the pixel is off the map.
std::vector<Eigen::Vector2i> column_spans(int pixels, double world_at_pixel0, double step, double voxel,
                                          int first_column, int columns) {
  std::vector<Eigen::Vector2i> spans(static_cast<std::size_t>(pixels));
  for (int p = 0; p < pixels; ++p) {
    const double a = world_at_pixel0 + step * p, b = a + step;
    const double lo = std::min(a, b), hi = std::max(a, b);
    int c0 = io::saturated_floor(lo / voxel + 0.5) - first_column;
    int c1 = io::saturated_ceil(hi / voxel + 0.5) - 1 - first_column;
    if (c1 < c0) c1 = c0;  // a pixel inside one column
    c0 = std::max(c0, 0);
    c1 = std::min(c1, columns - 1);
    spans[static_cast<std::size_t>(p)] = {c0, c1};
  }
  return spans;
}

void paint_map(Image& image, const MapRaster& raster, const TopDownTransform& view) {
  const Eigen::Vector4i area = view.area();
  const double mpp = view.metres_per_pixel();
  const Eigen::Vector2d top_left =
      view.to_world(Eigen::Vector2f(static_cast<float>(area.x()), static_cast<float>(area.y())));
  const auto xs = column_spans(area.z() - area.x(), top_left.x(), mpp, raster.voxel_size(), raster.first_column().x(),
                               raster.columns_x());
  const auto ys = column_spans(area.w() - area.y(), top_left.y(), -mpp, raster.voxel_size(), raster.first_column().y(),
                               raster.columns_y());
  for (int py = 0; py < area.w() - area.y(); ++py) {
    const Eigen::Vector2i sy = ys[static_cast<std::size_t>(py)];
    for (int px = 0; px < area.z() - area.x(); ++px) {
      const Eigen::Vector2i sx = xs[static_cast<std::size_t>(px)];
      int best_i = -1, best_j = -1, best_priority = -1;
      float best_value = -std::numeric_limits<float>::infinity();
      for (int j = sy.x(); j <= sy.y(); ++j) {
        for (int i = sx.x(); i <= sx.y(); ++i) {
          const int p = priority(raster.cell(i, j));
          const float v = raster.value(i, j);
          // Among equals the highest obstacle or the deepest inside wins, so that tall walls stay visible.
          const float rank = raster.is_slice() ? -v : v;
          if (p > best_priority || (p == best_priority && rank > best_value)) {
            best_priority = p;
            best_value = rank;
            best_i = i;
            best_j = j;
          }
        }
      }
      image.set_pixel(area.x() + px, area.y() + py, best_i < 0 ? kUnknownColor : raster.color(best_i, best_j));
    }
  }
}

Eigen::Vector2f heading_in_pixels(const Pose& pose) {
  const Eigen::Vector3d forward = pose.linear() * Eigen::Vector3d::UnitX();
  return Eigen::Vector2f(static_cast<float>(forward.x()), static_cast<float>(-forward.y()));
}

// An arrow head pointing along dir (unit, pixels) with its tip at tip.
std::vector<Eigen::Vector2f> arrow(const Eigen::Vector2f& center, const Eigen::Vector2f& dir, float length) {
  const Eigen::Vector2f side(-dir.y(), dir.x());
  const Eigen::Vector2f tip = center + dir * (0.6f * length);
  const Eigen::Vector2f back = center - dir * (0.4f * length);
  return {tip, back + side * (0.45f * length), center - dir * (0.15f * length), back - side * (0.45f * length)};
}

// A filled arrow with a white rim, so that it reads on every background.
void draw_pose_arrow(Image& image, const Eigen::Vector2f& at, const Pose& pose, Rgb color, float size) {
  Eigen::Vector2f dir = heading_in_pixels(pose);
  if (dir.norm() < 1e-3f) {  // looking straight up or down: no heading to show
    image.fill_circle(at, size * 0.35f + 1.5f, colors::kWhite);
    image.fill_circle(at, size * 0.35f, color);
    return;
  }
  dir.normalize();
  // The rim is the outline stroked 4 pixels wide in white, the inner half of which the arrow covers again.
  std::vector<Eigen::Vector2f> shape = arrow(at, dir, size);
  shape.push_back(shape.front());
  image.draw_polyline(shape, colors::kWhite, 4.0f);
  image.fill_polygon(shape, color);
}

void draw_trajectory(Image& image, const TopDownTransform& view, const TrajectoryOverlay& t, float marker_scale) {
  if (t.poses.empty()) return;
  std::vector<double> steps;
  for (std::size_t i = 1; i < t.poses.size(); ++i) {
    steps.push_back((t.poses[i].translation() - t.poses[i - 1].translation()).head<2>().norm());
  }
  double jump = std::numeric_limits<double>::infinity();
  if (!steps.empty()) {
    std::vector<double> sorted = steps;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    jump = std::max(1.0, 3.0 * sorted[sorted.size() / 2]);
  }
  const float width = t.width;
  std::vector<Eigen::Vector2f> run;
  auto flush = [&] {
    if (run.size() == 1)
      image.fill_circle(run.front(), width, t.color, t.alpha);
    else if (t.dashed)
      image.draw_dashed_polyline(run, t.color, width, 4.0f * width, t.alpha);
    else
      image.draw_polyline(run, t.color, width, t.alpha);
    run.clear();
  };
  for (std::size_t i = 0; i < t.poses.size(); ++i) {
    if (i > 0 && steps[i - 1] > jump) flush();
    run.push_back(view.to_pixel(t.poses[i].translation().head<2>()));
  }
  flush();
  const Eigen::Vector2f start = view.to_pixel(t.poses.front().translation().head<2>());
  image.fill_circle(start, 4.0f * marker_scale, colors::kWhite);
  image.stroke_circle(start, 4.0f * marker_scale, t.color, 0.8f * marker_scale);
  draw_pose_arrow(image, view.to_pixel(t.poses.back().translation().head<2>()), t.poses.back(), t.color,
                  12.0f * marker_scale);
}

void draw_particles(Image& image, const TopDownTransform& view, const ParticleSnapshot& snapshot,
                    const MapViewOptions& options) {
  const auto& ps = snapshot.particles;
  if (ps.empty()) return;
  float max_w = 0.0f, min_w = std::numeric_limits<float>::infinity();
  for (const auto& p : ps) {
    max_w = std::max(max_w, p.weight);
    min_w = std::min(min_w, p.weight);
  }
  const bool by_weight = max_w > 0.0f && min_w < max_w * 0.999f;
  std::vector<std::size_t> order(ps.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  // Heavy particles last, on top of the light ones they would otherwise hide under.
  if (by_weight)
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return ps[a].weight < ps[b].weight; });
  const float r = options.particle_radius;
  // Tens of thousands of particles spread over a map (a global initialization) would paint it over completely at
  // full opacity; fainter dots then show their density and keep the map readable under them.
  const Eigen::Vector4i area = view.area();
  const double area_px = static_cast<double>(area.z() - area.x()) * (area.w() - area.y());
  const double dot_px = static_cast<double>(ps.size()) * 3.14159 * std::max(r, 0.5f) * std::max(r, 0.5f);
  const float opacity = std::clamp(static_cast<float>(0.25 * area_px / dot_px), 0.05f, options.particle_alpha);
  for (const std::size_t k : order) {
    const auto& p = ps[k];
    const Eigen::Vector2f at = view.to_pixel(p.position.head<2>().cast<double>());
    const float level = by_weight ? weight_level(p.weight, max_w) : 1.0f;
    const Rgb color = by_weight ? particle_weight_color(options.particle_color, level) : options.particle_color;
    const float alpha = opacity * (by_weight ? 0.4f + 0.6f * level : 1.0f);
    image.fill_circle(at, r, color, alpha);
    if (options.particle_headings) {
      Pose pose = Pose::Identity();
      pose.linear() = p.orientation.cast<double>().toRotationMatrix();
      const Eigen::Vector2f dir = heading_in_pixels(pose);
      if (dir.norm() > 1e-3f)
        image.draw_line(at, at + dir.normalized() * (4.0f * r), color, std::max(1.0f, r / 2.0f), alpha);
    }
  }
}

bool has_weights(const ParticleSnapshot& snapshot) {
  if (snapshot.particles.empty()) return false;
  const auto [lo, hi] = std::minmax_element(snapshot.particles.begin(), snapshot.particles.end(),
                                            [](const auto& a, const auto& b) { return a.weight < b.weight; });
  return lo->weight < hi->weight * 0.999f;
}

// The world area of the figure: the known map and every overlay, with the padding around them.
Eigen::AlignedBox2d view_box(const MapRaster& raster, const std::vector<TrajectoryOverlay>& trajectories,
                             const std::vector<MapPanel>& panels, const MapViewOptions& options) {
  Eigen::AlignedBox2d box;  // empty
  if (auto known = raster.known_bounds()) box.extend(*known);
  for (const auto& t : trajectories) {
    for (const auto& pose : t.poses) {
      if (pose.translation().allFinite()) box.extend(Eigen::Vector2d(pose.translation().head<2>()));
    }
  }
  for (const auto& panel : panels) {
    for (const auto& p : panel.particles.particles) box.extend(p.position.head<2>().cast<double>());
    for (const auto& m : panel.markers) box.extend(Eigen::Vector2d(m.pose.translation().head<2>()));
  }
  if (box.isEmpty()) {
    throw Error("nothing to draw: no known voxel in the " + std::string(raster.is_slice() ? "slice" : "z-range") +
                " and no overlay");
  }
  box.min() -= Eigen::Vector2d::Constant(options.padding);
  box.max() += Eigen::Vector2d::Constant(options.padding);
  box.max() = box.min() + box.sizes().cwiseMax(Eigen::Vector2d::Constant(raster.voxel_size()));
  return box;
}

std::vector<LegendEntry> legend_entries(const std::vector<TrajectoryOverlay>& trajectories,
                                        const std::vector<MapPanel>& panels, const MapViewOptions& options) {
  std::vector<LegendEntry> legend;
  for (const auto& t : trajectories) {
    if (t.label.empty()) continue;
    legend.push_back({t.label, mix(colors::kWhite, t.color, t.alpha),
                      t.dashed ? LegendEntry::Symbol::kDashedLine : LegendEntry::Symbol::kLine});
  }
  // Each trajectory's start is a ring in its colour (an estimate's is its first estimate, where the search
  // began), so the legend names one ring per trajectory.
  for (const auto& t : trajectories) {
    if (t.label.empty()) continue;
    const std::string name = t.label.substr(0, t.label.find(" ("));  // without its "(final error ...)"
    legend.push_back({name + ": start", mix(colors::kWhite, t.color, t.alpha), LegendEntry::Symbol::kRing});
  }
  if (!trajectories.empty()) legend.push_back({"end, heading", colors::kText, LegendEntry::Symbol::kArrow});
  if (std::any_of(panels.begin(), panels.end(), [](const MapPanel& p) { return !p.particles.particles.empty(); })) {
    legend.push_back({"particles", options.particle_color, LegendEntry::Symbol::kDot});
  }
  std::vector<std::string> seen_markers;
  for (const auto& panel : panels) {
    for (const auto& m : panel.markers) {
      if (m.label.empty() || std::find(seen_markers.begin(), seen_markers.end(), m.label) != seen_markers.end())
        continue;
      seen_markers.push_back(m.label);
      legend.push_back({m.label, m.color, LegendEntry::Symbol::kArrow});
    }
  }
  legend.push_back({"not observed", kUnknownColor, LegendEntry::Symbol::kBand});
  legend.push_back({"free", kFreeColor, LegendEntry::Symbol::kBand});
  return legend;
}

// Panels in a grid whose shape comes closest to a screen's (16:10), so that captions stay readable when the
// figure is shown at screen width: a 50 x 20 m floor plan in five panels becomes two columns of three rows.
int grid_columns(int n, int panel_w, int panel_h) {
  int best = 1;
  double best_error = 1e300;
  for (int columns = 1; columns <= n; ++columns) {
    const int rows = (n + columns - 1) / columns;
    const double aspect = static_cast<double>(columns) * panel_w / (static_cast<double>(rows) * panel_h);
    const double error = std::abs(std::log(aspect / 1.6));
    if (error < best_error - 1e-9) {
      best = columns;
      best_error = error;
    }
  }
  return best;
}

struct ColorBar {
  std::string caption, lo, hi;
  std::function<Rgb(float)> colormap;
  float width = 0.0f;
};

// The map's colour scale (obstacle height or signed distance) and, for weighted particles, their weight scale.
std::vector<ColorBar> color_bars(const MapRaster& raster, bool weighted_particles, const MapViewOptions& options,
                                 float ts) {
  std::vector<ColorBar> bars;
  char caption[96];
  if (raster.is_slice()) {
    std::snprintf(caption, sizeof(caption), "signed distance, slice z = %.2f m", static_cast<double>(raster.z_min()));
    const float trunc = raster.truncation();
    bars.push_back({caption, format_metres(-trunc), "+" + format_metres(trunc), [trunc](float t) {
                      const float d = (2.0f * t - 1.0f) * trunc;
                      return d >= 0.0f ? mix(kNearSurfaceColor, kFreeColor, d / trunc)
                                       : mix(kInsideColor, kDeepInsideColor, -d / trunc);
                    }});
  } else {
    std::snprintf(caption, sizeof(caption), "obstacle height (z range %.2f .. %.2f m)",
                  static_cast<double>(raster.z_min()), static_cast<double>(raster.z_max()));
    bars.push_back({caption, format_metres(raster.obstacle_min()), format_metres(raster.obstacle_max()), height_color});
  }
  if (weighted_particles) {
    const Rgb strong = options.particle_color;
    bars.push_back(
        {"particle weight / max", "1e-3", "1", [strong](float t) { return particle_weight_color(strong, t); }});
  }
  for (auto& bar : bars) bar.width = std::max(100.0f * ts, text_size(bar.caption, ts).x());
  return bars;
}

// One panel: the map, the scale bar, the trajectories, the markers and the particles, clipped to the panel's area.
void draw_panel(Image& image, const MapRaster& raster, const TopDownTransform& view, const MapPanel& panel,
                const std::vector<TrajectoryOverlay>& trajectories, const MapViewOptions& options, float ts, int pad) {
  const Eigen::Vector4i area = view.area();
  if (!panel.caption.empty()) {
    image.draw_text(static_cast<float>(area.x()), static_cast<float>(area.y() - pad / 2), panel.caption,
                    {ts, colors::kText, HAlign::kLeft, VAlign::kBottom, false});
  }
  paint_map(image, raster, view);
  image.set_clip(area.x(), area.y(), area.z(), area.w());
  // Under the overlays: in a small panel the bar may have to cover part of the map, never the robot.
  draw_scale_bar(image, view, static_cast<float>(area.x() + pad * 2), static_cast<float>(area.w() - pad * 2),
                 static_cast<float>(area.z() - area.x()) / 4.0f, ts);
  for (const auto& t : trajectories) draw_trajectory(image, view, t, ts);
  // Markers summarize the particles; drawn under them, a converged cloud stays visible on its own marker.
  for (const auto& m : panel.markers) {
    const Eigen::Vector2f at = view.to_pixel(m.pose.translation().head<2>());
    draw_pose_arrow(image, at, m.pose, m.color, 14.0f * ts);
    if (!m.annotation.empty()) {
      image.draw_text(at.x() + 12.0f * ts, at.y() - 12.0f * ts, m.annotation,
                      {ts, m.color, HAlign::kLeft, VAlign::kBottom, false});
    }
  }
  draw_particles(image, view, panel.particles, options);
  image.reset_clip();
  image.stroke_rect(static_cast<float>(area.x() - 1), static_cast<float>(area.y() - 1),
                    static_cast<float>(area.z() + 1), static_cast<float>(area.w() + 1), colors::kAxis);
}

}  // namespace

MapFigure render_map_view(const MapRaster& raster, const std::vector<TrajectoryOverlay>& trajectories,
                          const std::vector<MapPanel>& panels_in, const MapViewOptions& options) {
  const std::vector<MapPanel> panels = panels_in.empty() ? std::vector<MapPanel>(1) : panels_in;
  if (!(options.text_scale >= 0.0f)) throw Error("text scale must not be negative");
  if (!(options.padding >= 0.0) || !std::isfinite(options.padding)) throw Error("view padding must be >= 0 m");
  const Eigen::AlignedBox2d box = view_box(raster, trajectories, panels, options);
  double mpp = options.metres_per_pixel;
  if (mpp == 0.0) {
    if (options.panel_pixels < 16) throw Error("panel size must be at least 16 pixels");
    mpp = box.sizes().maxCoeff() / options.panel_pixels;
  }
  if (!(mpp > 0.0) || !std::isfinite(mpp)) throw Error("pixel size must be a positive number of metres");
  const TopDownTransform base(box.min(), box.max(), mpp);
  const int panel_w = base.width(), panel_h = base.height();
  // Text grows with the panels so that it stays readable when a large figure is viewed scaled down.
  const float ts = options.text_scale > 0.0f
                       ? options.text_scale
                       : std::clamp(static_cast<float>(std::max(panel_w, panel_h)) / 450.0f, 1.5f, 2.5f);

  // Layout, top to bottom: title, rows of captioned panels, legend and colour bars.
  const float line = 12.0f * ts;
  const int pad = static_cast<int>(std::round(8.0f * ts));
  const bool captions = std::any_of(panels.begin(), panels.end(), [](const MapPanel& p) { return !p.caption.empty(); });
  const int title_h = options.title.empty() ? 0 : static_cast<int>(std::round(1.3f * line)) + pad;
  const int caption_h = captions ? static_cast<int>(std::round(line)) : 0;
  const std::vector<LegendEntry> legend = legend_entries(trajectories, panels, options);
  const Eigen::Vector2f legend_box = legend_size(legend, ts);
  const std::vector<ColorBar> bars = color_bars(
      raster, std::any_of(panels.begin(), panels.end(), [](const MapPanel& p) { return has_weights(p.particles); }),
      options, ts);
  float footer_w = legend_box.x();
  for (const auto& bar : bars) footer_w += 2.0f * pad + bar.width;
  const int footer_h = io::saturated_ceil(std::max(legend_box.y(), 3.0f * line));

  const int n = static_cast<int>(panels.size());
  const int columns = grid_columns(n, panel_w, panel_h);
  const int rows = (n + columns - 1) / columns;
  const int panels_w = columns * panel_w + (columns - 1) * 2 * pad;
  const int width = 2 * pad + std::max(panels_w, io::saturated_ceil(footer_w));
  const int caption_block = captions ? caption_h + pad / 2 : 0;
  const int panels_top = pad + title_h + caption_block;
  const int row_step = panel_h + pad + caption_block;
  const int height = panels_top + rows * row_step - caption_block + footer_h + pad;
  if (width > kMaxImageSide || height > kMaxImageSide) {
    throw Error("figure of " + std::to_string(width) + " x " + std::to_string(height) +
                " pixels is too large: choose a coarser pixel size");
  }
  MapFigure figure;
  figure.image = Image(width, height, colors::kWhite);
  Image& image = figure.image;
  if (!options.title.empty()) {
    image.draw_text(static_cast<float>(width) / 2.0f, static_cast<float>(pad), options.title,
                    {1.3f * ts, colors::kText, HAlign::kCenter, VAlign::kTop, false});
  }
  const int x_start = pad + (width - 2 * pad - panels_w) / 2;
  for (int k = 0; k < n; ++k) {
    figure.panels.push_back(
        base.moved_to({x_start + (k % columns) * (panel_w + 2 * pad), panels_top + (k / columns) * row_step}));
    draw_panel(image, raster, figure.panels.back(), panels[static_cast<std::size_t>(k)], trajectories, options, ts,
               pad);
  }

  const float footer_y = static_cast<float>(panels_top + (rows - 1) * row_step + panel_h + pad);
  // Aligned with the panels where it fits beside them, from the left margin where it is the wider part.
  float fx = static_cast<float>(x_start + footer_w <= width - pad ? x_start : pad);
  draw_legend(image, fx, footer_y, legend, ts);
  fx += legend_box.x();
  for (const auto& bar : bars) {
    fx += 2.0f * pad;
    draw_colorbar(image, fx, footer_y, bar.width, bar.colormap, bar.lo, bar.hi, bar.caption, ts);
    fx += bar.width;
  }
  return figure;
}

std::vector<PoseMarker> hypothesis_markers(const ParticleSnapshot& snapshot) {
  std::vector<PoseMarker> markers;
  for (const ParticleSnapshot::Particle& h : snapshot.hypotheses) {
    if (h.weight < 0.01f || markers.size() == 4) break;
    char share[16];
    std::snprintf(share, sizeof(share), "%.0f %%", 100.0 * h.weight);
    Pose pose = Pose::Identity();
    pose.translation() = h.position.cast<double>();
    pose.linear() = h.orientation.cast<double>().toRotationMatrix();
    markers.push_back({pose, palette_color(0), markers.empty() ? "hypotheses (share of the weight)" : "", share});
  }
  return markers;
}

}  // namespace tsdf_mcl
