#include "tsdf_mcl/line_plot.hpp"

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC  // private to this file: another part of the program may embed stb too
#include <stb_image_write.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl {
namespace {

// 5x7 glyphs, one byte per row, bit 4 = leftmost pixel.
const std::map<char, std::array<std::uint8_t, 7>>& font() {
  static const std::map<char, std::array<std::uint8_t, 7>> glyphs = {
    {' ', {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}},
    {'(', {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}},
    {')', {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08}},
    {'+', {0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00}},
    {'-', {0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00}},
    {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C}},
    {'/', {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00}},
    {'0', {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}},
    {'1', {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'2', {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}},
    {'3', {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E}},
    {'4', {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}},
    {'5', {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E}},
    {'6', {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}},
    {'7', {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
    {'8', {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}},
    {'9', {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}},
    {':', {0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00}},
    {'=', {0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00}},
    {'[', {0x0E, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0E}},
    {']', {0x0E, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0E}},
    {'a', {0x00, 0x00, 0x0E, 0x01, 0x0F, 0x11, 0x0F}},
    {'b', {0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x1E}},
    {'c', {0x00, 0x00, 0x0E, 0x10, 0x10, 0x11, 0x0E}},
    {'d', {0x01, 0x01, 0x0D, 0x13, 0x11, 0x11, 0x0F}},
    {'e', {0x00, 0x00, 0x0E, 0x11, 0x1F, 0x10, 0x0E}},
    {'f', {0x06, 0x09, 0x08, 0x1C, 0x08, 0x08, 0x08}},
    {'g', {0x00, 0x0F, 0x11, 0x11, 0x0F, 0x01, 0x0E}},
    {'h', {0x10, 0x10, 0x16, 0x19, 0x11, 0x11, 0x11}},
    {'i', {0x04, 0x00, 0x0C, 0x04, 0x04, 0x04, 0x0E}},
    {'k', {0x10, 0x10, 0x12, 0x14, 0x18, 0x14, 0x12}},
    {'l', {0x0C, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E}},
    {'m', {0x00, 0x00, 0x1A, 0x15, 0x15, 0x11, 0x11}},
    {'n', {0x00, 0x00, 0x16, 0x19, 0x11, 0x11, 0x11}},
    {'o', {0x00, 0x00, 0x0E, 0x11, 0x11, 0x11, 0x0E}},
    {'p', {0x00, 0x00, 0x1E, 0x11, 0x1E, 0x10, 0x10}},
    {'r', {0x00, 0x00, 0x16, 0x19, 0x10, 0x10, 0x10}},
    {'s', {0x00, 0x00, 0x0F, 0x10, 0x0E, 0x01, 0x1E}},
    {'t', {0x08, 0x08, 0x1C, 0x08, 0x08, 0x09, 0x06}},
    {'u', {0x00, 0x00, 0x11, 0x11, 0x11, 0x13, 0x0D}},
    {'v', {0x00, 0x00, 0x11, 0x11, 0x11, 0x0A, 0x04}},
    {'w', {0x00, 0x00, 0x11, 0x11, 0x15, 0x15, 0x0A}},
    {'x', {0x00, 0x00, 0x11, 0x0A, 0x04, 0x0A, 0x11}},
    {'y', {0x00, 0x00, 0x11, 0x11, 0x0F, 0x01, 0x0E}},
    {'z', {0x00, 0x00, 0x1F, 0x02, 0x04, 0x08, 0x1F}},
    {'|', {0x04, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04}},
  };
  return glyphs;
}

constexpr int kScale = 2;                   // font pixels per glyph pixel
constexpr int kAdvance = 6 * kScale;        // glyph width plus one column of spacing
constexpr int kGlyphHeight = 7 * kScale;

class Canvas {
 public:
  Canvas(int w, int h) : w_(w), h_(h), rgb_(static_cast<std::size_t>(w) * h * 3, 255) {}
  void set(int x, int y, const Rgb& c) {
    if (x < 0 || y < 0 || x >= w_ || y >= h_) return;
    const std::size_t i = (static_cast<std::size_t>(y) * w_ + x) * 3;
    rgb_[i] = c[0];
    rgb_[i + 1] = c[1];
    rgb_[i + 2] = c[2];
  }
  void fill(int x0, int y0, int x1, int y1, const Rgb& c) {
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) set(x, y, c);
  }
  // Bresenham, `thickness` pixels wide; dashed if dash > 0 (pixels on, pixels off).
  void line(int x0, int y0, int x1, int y1, const Rgb& c, int thickness = 1, int dash = 0) {
    const int dx = std::abs(x1 - x0), dy = -std::abs(y1 - y0);
    const int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
    int err = dx + dy;
    for (int step = 0;; ++step) {
      if (dash == 0 || (step / dash) % 2 == 0) {
        for (int t = 0; t < thickness; ++t) {
          const int o = t - thickness / 2;
          set(x0 + (dy != 0 && dx <= -dy ? o : 0), y0 + (dx > -dy ? o : 0), c);
        }
      }
      if (x0 == x1 && y0 == y1) break;
      const int e2 = 2 * err;
      if (e2 >= dy) {
        err += dy;
        x0 += sx;
      }
      if (e2 <= dx) {
        err += dx;
        y0 += sy;
      }
    }
  }
  void text(int x, int y, const std::string& s, const Rgb& c) {
    for (char ch : s) {
      const auto it = font().find(static_cast<char>(std::tolower(static_cast<unsigned char>(ch))));
      if (it != font().end()) {
        for (int row = 0; row < 7; ++row)
          for (int col = 0; col < 5; ++col) {
            if (it->second[static_cast<std::size_t>(row)] & (0x10 >> col)) {
              fill(x + col * kScale, y + row * kScale, x + col * kScale + kScale - 1, y + row * kScale + kScale - 1, c);
            }
          }
      }
      x += kAdvance;
    }
  }
  static int text_width(const std::string& s) { return static_cast<int>(s.size()) * kAdvance - kScale; }
  std::vector<std::uint8_t> take() { return std::move(rgb_); }

 private:
  int w_, h_;
  std::vector<std::uint8_t> rgb_;
};

std::string tick_label(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, std::abs(v) < step * 1e-6 ? 0.0 : v);
  return buf;
}

}  // namespace

std::vector<double> nice_ticks(double lo, double hi, int target) {
  if (!(hi > lo)) return {lo};
  const double raw = (hi - lo) / std::max(1, target);
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  double step = magnitude;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * magnitude;
    if (step >= raw) break;
  }
  std::vector<double> ticks;
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + step * 1e-9; v += step) ticks.push_back(v);
  return ticks;
}

std::vector<std::uint8_t> render_plot(const LinePlot& plot) {
  double x_lo = std::numeric_limits<double>::infinity();
  double x_hi = -x_lo;
  double y_lo = 0.0, y_hi = 0.0;
  bool any = false;
  for (const PlotSeries& s : plot.series) {
    if (s.x.size() != s.y.size()) throw Error("plot: series '" + s.label + "' has " + std::to_string(s.x.size()) + " x but " + std::to_string(s.y.size()) + " y values");
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      any = true;
      x_lo = std::min(x_lo, s.x[i]);
      x_hi = std::max(x_hi, s.x[i]);
      y_lo = std::min(y_lo, s.y[i]);
      y_hi = std::max(y_hi, s.y[i]);
    }
  }
  if (!any) throw Error("plot: no finite data points");
  if (plot.y_range) std::tie(y_lo, y_hi) = *plot.y_range;
  if (!(x_hi > x_lo)) x_hi = x_lo + 1.0;
  if (!(y_hi > y_lo)) y_hi = y_lo + 1.0;
  const double y_pad = 0.05 * (y_hi - y_lo);
  if (!plot.y_range) {
    y_hi += y_pad;
    if (y_lo < 0.0) y_lo -= y_pad;
  }

  const int w = plot.width, h = plot.height;
  if (w < 200 || h < 150) throw Error("plot: image too small");
  Canvas c(w, h);
  const int left = 90, right = w - 20, top = 50, bottom = h - 60;
  const auto px = [&](double x) { return left + static_cast<int>(std::lround((x - x_lo) / (x_hi - x_lo) * (right - left))); };
  const auto py = [&](double y) { return bottom - static_cast<int>(std::lround((y - y_lo) / (y_hi - y_lo) * (bottom - top))); };
  const Rgb black{0, 0, 0}, grid{225, 225, 225}, dark{90, 90, 90};

  const std::vector<double> xt = nice_ticks(x_lo, x_hi, 8);
  const std::vector<double> yt = nice_ticks(y_lo, y_hi, 6);
  const double x_step = xt.size() > 1 ? xt[1] - xt[0] : 1.0;
  const double y_step = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
  for (double v : xt) {
    c.line(px(v), top, px(v), bottom, grid);
    c.line(px(v), bottom, px(v), bottom + 6, black);
    const std::string label = tick_label(v, x_step);
    c.text(px(v) - Canvas::text_width(label) / 2, bottom + 10, label, black);
  }
  for (double v : yt) {
    c.line(left, py(v), right, py(v), grid);
    c.line(left - 6, py(v), left, py(v), black);
    const std::string label = tick_label(v, y_step);
    c.text(left - 10 - Canvas::text_width(label), py(v) - kGlyphHeight / 2, label, black);
  }
  if (y_lo < 0.0 && y_hi > 0.0) c.line(left, py(0.0), right, py(0.0), dark);
  c.line(left, top, left, bottom, black);
  c.line(left, bottom, right, bottom, black);
  c.line(left, top, right, top, black);
  c.line(right, top, right, bottom, black);

  for (const auto& [x, label] : plot.markers) {
    if (x < x_lo || x > x_hi) continue;
    c.line(px(x), top, px(x), bottom, dark, 1, 6);
    c.text(px(x) + 6, top + 6, label, dark);
  }
  for (const PlotSeries& s : plot.series) {
    bool have_prev = false;
    int x_prev = 0, y_prev = 0;
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) {
        have_prev = false;
        continue;
      }
      const int x = px(s.x[i]);
      const int y = std::clamp(py(s.y[i]), top, bottom);
      if (have_prev) c.line(x_prev, y_prev, x, y, s.color, 2);
      else c.fill(x - 1, y - 1, x + 1, y + 1, s.color);
      x_prev = x;
      y_prev = y;
      have_prev = true;
    }
  }

  // Legend in the top right corner of the axes.
  int legend_w = 0;
  for (const PlotSeries& s : plot.series) legend_w = std::max(legend_w, Canvas::text_width(s.label));
  legend_w += 50;
  const int legend_h = static_cast<int>(plot.series.size()) * (kGlyphHeight + 8) + 8;
  const int lx = right - legend_w - 10, ly = top + 10;
  c.fill(lx, ly, lx + legend_w, ly + legend_h, Rgb{255, 255, 255});
  c.line(lx, ly, lx + legend_w, ly, dark);
  c.line(lx, ly + legend_h, lx + legend_w, ly + legend_h, dark);
  c.line(lx, ly, lx, ly + legend_h, dark);
  c.line(lx + legend_w, ly, lx + legend_w, ly + legend_h, dark);
  for (std::size_t k = 0; k < plot.series.size(); ++k) {
    const int y = ly + 8 + static_cast<int>(k) * (kGlyphHeight + 8);
    c.fill(lx + 8, y + kGlyphHeight / 2 - 2, lx + 36, y + kGlyphHeight / 2 + 1, plot.series[k].color);
    c.text(lx + 44, y, plot.series[k].label, black);
  }

  c.text((left + right) / 2 - Canvas::text_width(plot.title) / 2, 14, plot.title, black);
  c.text((left + right) / 2 - Canvas::text_width(plot.x_label) / 2, h - 26, plot.x_label, black);
  c.text(8, top - kGlyphHeight - 8, plot.y_label, black);
  return c.take();
}

void write_plot_png(const LinePlot& plot, const std::filesystem::path& file) { write_plots_png({plot}, file); }

void write_plots_png(const std::vector<LinePlot>& plots, const std::filesystem::path& file) {
  if (plots.empty()) throw Error("plot: nothing to draw");
  std::vector<std::uint8_t> rgb;
  int height = 0;
  for (const LinePlot& plot : plots) {
    if (plot.width != plots.front().width) throw Error("plot: stacked plots need the same width");
    const std::vector<std::uint8_t> panel = render_plot(plot);
    rgb.insert(rgb.end(), panel.begin(), panel.end());
    height += plot.height;
  }
  const int width = plots.front().width;
  if (!stbi_write_png(file.c_str(), width, height, 3, rgb.data(), width * 3)) {
    throw Error("cannot write plot " + file.string());
  }
}

}  // namespace tsdf_mcl
