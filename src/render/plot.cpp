#include "tsdf_mcl/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "tsdf_mcl/error.hpp"

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

// Liang-Barsky: clips the segment a-b to the box; false if nothing of it is inside.
bool clip_segment(Eigen::Vector2d& a, Eigen::Vector2d& b, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  double t0 = 0.0, t1 = 1.0;
  const Eigen::Vector2d d = b - a;
  for (int axis = 0; axis < 2; ++axis) {
    const double p[2] = {-d[axis], d[axis]};
    const double q[2] = {a[axis] - lo[axis], hi[axis] - a[axis]};
    for (int k = 0; k < 2; ++k) {
      if (p[k] == 0.0) {
        if (q[k] < 0.0) return false;
        continue;
      }
      const double t = q[k] / p[k];
      if (p[k] < 0.0) t0 = std::max(t0, t);
      else t1 = std::min(t1, t);
    }
  }
  if (t0 > t1) return false;
  const Eigen::Vector2d start = a + t0 * d;
  b = a + t1 * d;
  a = start;
  return true;
}

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

Image render_plot(const LinePlot& plot) {
  for (const auto& s : plot.series) {
    if (s.x.size() != s.y.size()) {
      throw Error("plot series '" + s.label + "' has " + std::to_string(s.x.size()) + " x values but " +
                  std::to_string(s.y.size()) + " y values");
    }
  }
  const float ts = plot.text_scale;
  if (!(ts > 0.0f)) throw Error("plot text scale must be positive");
  const float line = 12.0f * ts;  // one text line
  const float pad = 6.0f * ts;

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

  // Approximate tick counts from the image size first; the plot area follows from the labels they need.
  const int max_x_ticks = std::clamp(plot.width / static_cast<int>(70.0f * ts), 3, 12);
  const int max_y_ticks = std::clamp(plot.height / static_cast<int>(30.0f * ts), 3, 10);
  Ticks xt = nice_ticks(xr.lo, xr.hi, max_x_ticks);
  Ticks yt = nice_ticks(yr.lo, yr.hi, max_y_ticks);
  // Fixed limits are kept exactly. The x axis (time) ends where the data ends, which a run's length rarely matches to
  // a tick; the y axis ends on ticks, so the extreme values can be read off a labelled grid line.
  const bool tight_x = xr.hi > xr.lo;
  const double x_lo = plot.x_min || tight_x ? xr.lo : xt.values.front();
  const double x_hi = plot.x_max || tight_x ? xr.hi : xt.values.back();
  const double y_lo = plot.y_min ? yr.lo : yt.values.front(), y_hi = plot.y_max ? yr.hi : yt.values.back();

  float y_label_width = 0.0f;
  for (double v : yt.values) y_label_width = std::max(y_label_width, text_size(format_tick(v, yt.decimals), ts).x());

  std::vector<LegendEntry> legend;
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    const auto& s = plot.series[i];
    if (!s.label.empty()) legend.push_back({s.label, s.color.value_or(palette_color(i)), LegendEntry::Symbol::kLine});
  }
  const Eigen::Vector2f legend_box = legend_size(legend, ts);

  const float left = pad + (plot.y_label.empty() ? 0.0f : line + pad) + y_label_width + pad;
  const float top = pad + (plot.title.empty() ? 0.0f : 1.3f * line + pad);
  const float right = pad + (legend.empty() ? 0.0f : legend_box.x() + pad);
  const float bottom = pad + line + (plot.x_label.empty() ? 0.0f : line + pad);
  const float px0 = std::round(left), py0 = std::round(top);
  const float px1 = std::round(static_cast<float>(plot.width) - right);
  const float py1 = std::round(static_cast<float>(plot.height) - bottom);
  if (px1 - px0 < 40.0f || py1 - py0 < 40.0f) {
    throw Error("plot of " + std::to_string(plot.width) + " x " + std::to_string(plot.height) +
                " pixels is too small for its labels");
  }

  Image image(plot.width, plot.height, colors::kWhite);
  auto to_px = [&](double x, double y) {
    return Eigen::Vector2d(px0 + (x - x_lo) / (x_hi - x_lo) * (px1 - px0), py1 - (y - y_lo) / (y_hi - y_lo) * (py1 - py0));
  };
  const TextStyle label_style{ts, colors::kText, HAlign::kCenter, VAlign::kTop, false};

  // Grid and tick labels.
  for (double v : xt.values) {
    if (v < x_lo - 1e-9 * (x_hi - x_lo) || v > x_hi + 1e-9 * (x_hi - x_lo)) continue;
    const float x = std::round(static_cast<float>(to_px(v, y_lo).x())) + 0.5f;
    image.draw_line({x, py0}, {x, py1}, colors::kGrid);
    image.draw_text(x, py1 + pad, format_tick(v, xt.decimals), label_style);
  }
  for (double v : yt.values) {
    if (v < y_lo - 1e-9 * (y_hi - y_lo) || v > y_hi + 1e-9 * (y_hi - y_lo)) continue;
    const float y = std::round(static_cast<float>(to_px(x_lo, v).y())) + 0.5f;
    image.draw_line({px0, y}, {px1, y}, colors::kGrid);
    image.draw_text(px0 - pad, y, format_tick(v, yt.decimals), {ts, colors::kText, HAlign::kRight, VAlign::kMiddle, false});
  }
  if (y_lo < 0.0 && y_hi > 0.0) {
    const float y = std::round(static_cast<float>(to_px(x_lo, 0.0).y())) + 0.5f;
    image.draw_line({px0, y}, {px1, y}, rgb_hex(0xb0b0b0));
  }
  image.stroke_rect(px0, py0, px1 + 1.0f, py1 + 1.0f, colors::kAxis);

  if (!plot.title.empty()) {
    image.draw_text(static_cast<float>(plot.width) / 2.0f, pad, plot.title,
                    {1.3f * ts, colors::kText, HAlign::kCenter, VAlign::kTop, false});
  }
  if (!plot.x_label.empty()) {
    image.draw_text((px0 + px1) / 2.0f, py1 + pad + line + pad, plot.x_label, label_style);
  }
  if (!plot.y_label.empty()) {
    image.draw_text(pad, (py0 + py1) / 2.0f, plot.y_label, {ts, colors::kText, HAlign::kCenter, VAlign::kTop, true});
  }

  // Everything in data space is clipped to the plot area; lines are clipped analytically first so that values far
  // outside fixed limits keep their true slope at the border.
  image.set_clip(static_cast<int>(px0) + 1, static_cast<int>(py0) + 1, static_cast<int>(px1), static_cast<int>(py1));
  const Eigen::Vector2d clip_lo(px0 - 10.0, py0 - 10.0), clip_hi(px1 + 10.0, py1 + 10.0);
  for (const auto& h : plot.horizontal_lines) {
    const float y = static_cast<float>(to_px(x_lo, h.y).y());
    if (h.dashed) image.draw_dashed_line({px0, y}, {px1, y}, h.color, 1.5f, 8.0f);
    else image.draw_line({px0, y}, {px1, y}, h.color, 1.5f);
    if (!h.label.empty() && y >= py0 && y <= py1) {
      // Labels face away from zero (or the middle, if zero is off the plot), so that the two labels of a band like
      // +-0.3 m sit outside it instead of on top of each other; at a border they turn inwards.
      const double centre = y_lo < 0.0 && y_hi > 0.0 ? 0.0 : (y_lo + y_hi) / 2.0;
      const bool below = (h.y < centre && py1 - y >= line) || y - py0 < line;
      image.draw_text(px1 - pad, below ? y + pad / 2.0f : y - pad / 2.0f, h.label,
                      {ts, h.color, HAlign::kRight, below ? VAlign::kTop : VAlign::kBottom, false});
    }
  }
  for (std::size_t i = 0; i < plot.series.size(); ++i) {
    const auto& s = plot.series[i];
    const Rgb color = s.color.value_or(palette_color(i));
    std::vector<Eigen::Vector2f> run;
    auto flush = [&] {
      if (!run.empty()) image.draw_polyline(run, color, s.width);
      run.clear();
    };
    for (std::size_t k = 0; k + 1 < s.x.size(); ++k) {
      if (!std::isfinite(s.x[k]) || !std::isfinite(s.y[k]) || !std::isfinite(s.x[k + 1]) || !std::isfinite(s.y[k + 1])) {
        flush();
        continue;
      }
      Eigen::Vector2d a = to_px(s.x[k], s.y[k]), b = to_px(s.x[k + 1], s.y[k + 1]);
      const Eigen::Vector2d a_before = a;
      if (!clip_segment(a, b, clip_lo, clip_hi)) {
        flush();
        continue;
      }
      if (a != a_before) flush();  // the segment enters from outside: a new run starts at the border
      if (run.empty()) run.push_back(a.cast<float>());
      run.push_back(b.cast<float>());
      if (b != to_px(s.x[k + 1], s.y[k + 1])) flush();  // it leaves the plot
    }
    // A lone finite point (between gaps, or the only one) would draw no segment: show it as a dot.
    for (std::size_t k = 0; k < s.x.size(); ++k) {
      const bool finite = std::isfinite(s.x[k]) && std::isfinite(s.y[k]);
      const bool prev = k > 0 && std::isfinite(s.x[k - 1]) && std::isfinite(s.y[k - 1]);
      const bool next = k + 1 < s.x.size() && std::isfinite(s.x[k + 1]) && std::isfinite(s.y[k + 1]);
      if (finite && !prev && !next) image.fill_circle(to_px(s.x[k], s.y[k]).cast<float>(), s.width, color);
    }
    flush();
  }
  for (const auto& m : plot.markers) {
    const float x = static_cast<float>(to_px(m.x, y_lo).x());
    image.draw_dashed_line({x, py0}, {x, py1}, m.color, 1.5f, 8.0f);
    if (!m.label.empty()) {
      const Eigen::Vector2f size = text_size(m.label, ts);
      const bool left_side = x + pad + size.x() > px1;  // no room to the right of the marker
      const float tx = left_side ? x - pad : x + pad;
      const float x0 = left_side ? tx - size.x() : tx;
      image.fill_rect(x0 - 2.0f, py0 + pad - 2.0f, x0 + size.x() + 2.0f, py0 + pad + size.y() + 2.0f, colors::kWhite, 0.8f);
      image.draw_text(tx, py0 + pad, m.label, {ts, m.color, left_side ? HAlign::kRight : HAlign::kLeft, VAlign::kTop, false});
    }
  }
  image.reset_clip();

  if (!legend.empty()) draw_legend(image, px1 + pad, py0, legend, ts);
  return image;
}

void write_plot_png(const LinePlot& plot, const std::filesystem::path& file) { save_png(render_plot(plot), file); }

}  // namespace tsdf_mcl
