// render_map_view: the raster painted into panels, with the trajectories, particles, hypotheses, legend and colour
// bars over it.
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
using render::kUnknownColor;

constexpr Rgb kWeakParticle = rgb_hex(0xfcbba1);

// Particle colour and opacity by weight relative to the heaviest, on a log scale over three decades: the weights of
// an unconverged filter span many orders of magnitude, and a linear scale would show all but a few as zero.
float weight_level(float weight, float max_weight) {
  if (!(weight > 0.0f) || !(max_weight > 0.0f)) return 0.0f;
  return std::clamp(1.0f + std::log10(weight / max_weight) / 3.0f, 0.0f, 1.0f);
}

Rgb particle_weight_color(Rgb strong, float level) { return mix(kWeakParticle, strong, level); }

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
    markers.push_back({pose, palette_color(0), markers.empty() ? "places (share of the belief)" : "", share});
  }
  return markers;
}

}  // namespace tsdf_mcl
