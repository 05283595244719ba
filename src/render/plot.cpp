#include "tsdf_mcl/render/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <utility>
#include <vector>

#include "clip.hpp"
#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl {
namespace {

// The smallest 1-2-5 x 10^k value not below x (> 0).
double nice_step_at_least(double x) {
  double step = nice_number_at_most(x);
  if (step >= x * (1.0 - 1e-12)) return step;
  const double magnitude = std::pow(10.0, std::floor(std::log10(step) + 1e-9));
  const double fraction = step / magnitude;
  return (fraction < 1.5 ? 2.0 : fraction < 3.5 ? 5.0 : 10.0) * magnitude;
}

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    if (!std::isfinite(v)) return;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  bool valid() const { return lo <= hi; }
};

}  // namespace

Ticks nice_ticks(double lo, double hi, int max_ticks) {
  if (!std::isfinite(lo) || !std::isfinite(hi)) throw Error("axis range is not finite");
  if (hi < lo) std::swap(lo, hi);
  if (hi - lo <= std::max(std::abs(lo), std::abs(hi)) * 1e-12) {
    const double pad = lo != 0.0 ? std::abs(lo) * 0.1 : 1.0;
    lo -= pad;
    hi += pad;
  }
  max_ticks = std::max(max_ticks, 2);
  Ticks ticks;
  double step = nice_step_at_least((hi - lo) / (max_ticks - 1));
  // Rounding the ends outwards can add a tick at either side; a larger step then fits.
  for (;;) {
    // The 1e-9 absorbs division rounding (0.3 / 0.1 = 2.9999999999999996 must give the tick at 0.3).
    const double first = std::floor(lo / step + 1e-9);
    const double last = std::ceil(hi / step - 1e-9);
    if (last - first + 1.0 <= max_ticks) {
      ticks.step = step;
      for (double i = first; i <= last; i += 1.0) ticks.values.push_back(i * step);
      break;
    }
    step = nice_step_at_least(step * 1.5);
  }
  ticks.decimals = std::max(0, static_cast<int>(-std::floor(std::log10(ticks.step) + 1e-9)));
  return ticks;
}

std::string format_tick(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", std::clamp(decimals, 0, 12), value);
  std::string s = text;
  // "-0.0" and friends: the sign of a value that rounds to zero is noise.
  if (s.front() == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

namespace {

// Where everything goes: the axes' limits and ticks, the plot area in image pixels and the legend.
struct PlotLayout {
  float ts = 1.0f;    // text scale
  float line = 0.0f;  // one text line
  float pad = 0.0f;
  Ticks xt, yt;
  double x_lo = 0.0, x_hi = 1.0, y_lo = 0.0, y_hi = 1.0;
  float px0 = 0.0f, py0 = 0.0f, px1 = 0.0f, py1 = 0.0f;
  std::vector<LegendEntry> legend;

  Eigen::Vector2d to_px(double x, double y) const {
    return {px0 + (x - x_lo) / (x_hi - x_lo) * (px1 - px0), py1 - (y - y_lo) / (y_hi - y_lo) * (py1 - py0)};
  }
};

// The ranges the axes cover: the data, the reference lines and the markers, or the fixed limits.
std::pair<Range, Range> axis_ranges(const LinePlot& plot) {
  Range xr, yr;
  for (const auto& s : plot.series) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      xr.add(s.x[i]);
      yr.add(s.y[i]);
    }
  }
  for (const auto& h : plot.horizontal_lines) yr.add(h.y);
  for (const auto& m : plot.markers) xr.add(m.x);
  if (!xr.valid()) xr = {0.0, 1.0};
  if (!yr.valid()) yr = {0.0, 1.0};
  if (plot.x_min) xr.lo = *plot.x_min;
  if (plot.x_max) xr.hi = *plot.x_max;
  if (plot.y_min) yr.lo = *plot.y_min;
  if (plot.y_max) yr.hi = *plot.y_max;
  if (!std::isfinite(xr.lo) || !std::isfinite(xr.hi) || !std::isfinite(yr.lo) || !std::isfinite(yr.hi) ||
      ((plot.x_min || plot.x_max) && !(xr.lo < xr.hi)) || ((plot.y_min || plot.y_max) && !(yr.lo < yr.hi))) {
    throw Error("plot axis limits are empty, inverted or not finite");
  }
  return {xr, yr};
}

PlotLayout layout_plot(const LinePlot& plot) {
  PlotLayout l;
  l.ts = plot.text_scale;
  l.line = 12.0f * l.ts;
  l.pad = 6.0f * l.ts;
  const auto [xr, yr] = axis_ranges(plot);
  // Approximate tick counts from the image size first; the plot area follows from the labels they need.
  const int max_x_ticks = std::clamp(plot.width / static_cast<int>(70.0f * l.ts), 3, 12);
  const int max_y_ticks = std::clamp(plot.height / static_cast<int>(30.0f * l.ts), 3, 10);
  l.xt = nice_ticks(xr.lo, xr.hi, max_x_ticks);
  l.yt = nice_ticks(yr.lo, yr.hi, max_y_ticks);
  // Fixed limits are kept exactly. The x axis (time) ends where the data ends, which a run's length rarely matches to
  // a tick; the y axis ends on ticks, so the extreme values can be read off a labelled grid line.
  const bool tight_x = xr.hi > xr.lo;
  l.x_lo = plot.x_min || tight_x ? xr.lo : l.xt.values.front();
  l.x_hi = plot.x_max || tight_x ? xr.hi : l.xt.values.back();
  l.y_lo = plot.y_min ? yr.lo : l.yt.values.front();
  l.y_hi = plot.y_max ? yr.hi : l.yt.values.back();

  float y_label_width = 0.0f;
  for (double v : l.yt.values)
    y_label_width = std::max(y_label_width, text_size(format_tick(v, l.yt.decimals), l.ts).x());
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    const auto& s = plot.series[i];
    if (!s.label.empty()) l.legend.push_back({s.label, s.color.value_or(palette_color(i)), LegendEntry::Symbol::kLine});
  }
  const Eigen::Vector2f legend_box = legend_size(l.legend, l.ts);

  const float left = l.pad + (plot.y_label.empty() ? 0.0f : l.line + l.pad) + y_label_width + l.pad;
  const float top = l.pad + (plot.title.empty() ? 0.0f : 1.3f * l.line + l.pad);
  const float right = l.pad + (l.legend.empty() ? 0.0f : legend_box.x() + l.pad);
  const float bottom = l.pad + l.line + (plot.x_label.empty() ? 0.0f : l.line + l.pad);
  l.px0 = std::round(left);
  l.py0 = std::round(top);
  l.px1 = std::round(static_cast<float>(plot.width) - right);
  l.py1 = std::round(static_cast<float>(plot.height) - bottom);
  if (l.px1 - l.px0 < 40.0f || l.py1 - l.py0 < 40.0f) {
    throw Error("plot of " + std::to_string(plot.width) + " x " + std::to_string(plot.height) +
                " pixels is too small for its labels");
  }
  return l;
}

// Grid, tick labels, the zero line, the frame, the title and the axis labels.
void draw_axes(Image& image, const LinePlot& plot, const PlotLayout& l) {
  const TextStyle label_style{l.ts, colors::kText, HAlign::kCenter, VAlign::kTop, false};
  for (double v : l.xt.values) {
    if (v < l.x_lo - 1e-9 * (l.x_hi - l.x_lo) || v > l.x_hi + 1e-9 * (l.x_hi - l.x_lo)) continue;
    const float x = std::round(static_cast<float>(l.to_px(v, l.y_lo).x())) + 0.5f;
    image.draw_line({x, l.py0}, {x, l.py1}, colors::kGrid);
    image.draw_text(x, l.py1 + l.pad, format_tick(v, l.xt.decimals), label_style);
  }
  for (double v : l.yt.values) {
    if (v < l.y_lo - 1e-9 * (l.y_hi - l.y_lo) || v > l.y_hi + 1e-9 * (l.y_hi - l.y_lo)) continue;
    const float y = std::round(static_cast<float>(l.to_px(l.x_lo, v).y())) + 0.5f;
    image.draw_line({l.px0, y}, {l.px1, y}, colors::kGrid);
    image.draw_text(l.px0 - l.pad, y, format_tick(v, l.yt.decimals),
                    {l.ts, colors::kText, HAlign::kRight, VAlign::kMiddle, false});
  }
  if (l.y_lo < 0.0 && l.y_hi > 0.0) {
    const float y = std::round(static_cast<float>(l.to_px(l.x_lo, 0.0).y())) + 0.5f;
    image.draw_line({l.px0, y}, {l.px1, y}, rgb_hex(0xb0b0b0));
  }
  image.stroke_rect(l.px0, l.py0, l.px1 + 1.0f, l.py1 + 1.0f, colors::kAxis);

  if (!plot.title.empty()) {
    image.draw_text(static_cast<float>(plot.width) / 2.0f, l.pad, plot.title,
                    {1.3f * l.ts, colors::kText, HAlign::kCenter, VAlign::kTop, false});
  }
  if (!plot.x_label.empty()) {
    image.draw_text((l.px0 + l.px1) / 2.0f, l.py1 + l.pad + l.line + l.pad, plot.x_label, label_style);
  }
  if (!plot.y_label.empty()) {
    image.draw_text(l.pad, (l.py0 + l.py1) / 2.0f, plot.y_label,
                    {l.ts, colors::kText, HAlign::kCenter, VAlign::kTop, true});
  }
}

void draw_horizontal_lines(Image& image, const LinePlot& plot, const PlotLayout& l) {
  for (const auto& h : plot.horizontal_lines) {
    const float y = static_cast<float>(l.to_px(l.x_lo, h.y).y());
    if (h.dashed)
      image.draw_dashed_line({l.px0, y}, {l.px1, y}, h.color, 1.5f, 8.0f);
    else
      image.draw_line({l.px0, y}, {l.px1, y}, h.color, 1.5f);
    if (h.label.empty() || !(y >= l.py0 && y <= l.py1)) continue;
    // Labels face away from zero (or the middle, if zero is off the plot), so that the two labels of a band like
    // +-0.3 m sit outside it instead of on top of each other; at a border they turn inwards.
    const double centre = l.y_lo < 0.0 && l.y_hi > 0.0 ? 0.0 : (l.y_lo + l.y_hi) / 2.0;
    const bool below = (h.y < centre && l.py1 - y >= l.line) || y - l.py0 < l.line;
    image.draw_text(l.px1 - l.pad, below ? y + l.pad / 2.0f : y - l.pad / 2.0f, h.label,
                    {l.ts, h.color, HAlign::kRight, below ? VAlign::kTop : VAlign::kBottom, false});
  }
}

// Lines are clipped analytically first so that values far outside fixed limits keep their true slope at the border
// (and values beyond float's range still draw).
void draw_series(Image& image, const PlotSeries& s, Rgb color, const PlotLayout& l) {
  const Eigen::Vector2d clip_lo(l.px0 - 10.0, l.py0 - 10.0), clip_hi(l.px1 + 10.0, l.py1 + 10.0);
  auto finite = [&s](std::size_t k) { return std::isfinite(s.x[k]) && std::isfinite(s.y[k]); };
  std::vector<Eigen::Vector2f> run;
  auto flush = [&] {
    if (!run.empty()) image.draw_polyline(run, color, s.width);
    run.clear();
  };
  for (std::size_t k = 0; k + 1 < s.x.size(); ++k) {
    if (!finite(k) || !finite(k + 1)) {
      flush();
      continue;
    }
    const Eigen::Vector2d a_in = l.to_px(s.x[k], s.y[k]), b_in = l.to_px(s.x[k + 1], s.y[k + 1]);
    Eigen::Vector2d a = a_in, b = b_in;
    if (!render::clip_segment(a, b, clip_lo, clip_hi)) {
      flush();
      continue;
    }
    if (a != a_in) flush();  // the segment enters from outside: a new run starts at the border
    if (run.empty()) run.push_back(a.cast<float>());
    run.push_back(b.cast<float>());
    if (b != b_in) flush();  // it leaves the plot
  }
  flush();
  // A lone finite point (between gaps, or the only one) draws no segment: show it as a dot.
  for (std::size_t k = 0; k < s.x.size(); ++k) {
    if (finite(k) && !(k > 0 && finite(k - 1)) && !(k + 1 < s.x.size() && finite(k + 1))) {
      image.fill_circle(l.to_px(s.x[k], s.y[k]).cast<float>(), s.width, color);
    }
  }
}

void draw_markers(Image& image, const LinePlot& plot, const PlotLayout& l) {
  for (const auto& m : plot.markers) {
    const float x = static_cast<float>(l.to_px(m.x, l.y_lo).x());
    image.draw_dashed_line({x, l.py0}, {x, l.py1}, m.color, 1.5f, 8.0f);
    if (m.label.empty()) continue;
    const Eigen::Vector2f size = text_size(m.label, l.ts);
    const bool left_side = x + l.pad + size.x() > l.px1;  // no room to the right of the marker
    const float tx = left_side ? x - l.pad : x + l.pad;
    const float x0 = left_side ? tx - size.x() : tx;
    image.fill_rect(x0 - 2.0f, l.py0 + l.pad - 2.0f, x0 + size.x() + 2.0f, l.py0 + l.pad + size.y() + 2.0f,
                    colors::kWhite, 0.8f);
    image.draw_text(tx, l.py0 + l.pad, m.label,
                    {l.ts, m.color, left_side ? HAlign::kRight : HAlign::kLeft, VAlign::kTop, false});
  }
}

}  // namespace

Image render_plot(const LinePlot& plot) {
  for (const auto& s : plot.series) {
    if (s.x.size() != s.y.size()) {
      throw Error("plot series '" + s.label + "' has " + std::to_string(s.x.size()) + " x values but " +
                  std::to_string(s.y.size()) + " y values");
    }
  }
  if (!(plot.text_scale > 0.0f)) throw Error("plot text scale must be positive");
  const PlotLayout l = layout_plot(plot);
  Image image(plot.width, plot.height, colors::kWhite);
  draw_axes(image, plot, l);
  // Everything in data space is clipped to the plot area.
  image.set_clip(static_cast<int>(l.px0) + 1, static_cast<int>(l.py0) + 1, static_cast<int>(l.px1),
                 static_cast<int>(l.py1));
  draw_horizontal_lines(image, plot, l);
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    draw_series(image, plot.series[i], plot.series[i].color.value_or(palette_color(i)), l);
  }
  draw_markers(image, plot, l);
  image.reset_clip();
  if (!l.legend.empty()) draw_legend(image, l.px1 + l.pad, l.py0, l.legend, l.ts);
  return image;
}

void write_plot_png(const LinePlot& plot, const std::filesystem::path& file) { save_png(render_plot(plot), file); }

}  // namespace tsdf_mcl
