#pragma once
// Line plots of values over time (e.g. the translation error per axis of a localization run, as in the paper's
// figures). Fill a LinePlot and render it, or write it straight to a PNG file:
//
//   LinePlot plot;
//   plot.title = "translation error";
//   plot.y_label = "error [m]";
//   plot.series = {{"x", times, err_x}, {"y", times, err_y}, {"z", times, err_z}};
//   plot.horizontal_lines = {{0.3, "+0.3 m"}, {-0.3, "-0.3 m"}};
//   plot.markers.emplace_back(12.5, "converged");
//   write_plot_png(plot, "error.png");
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tsdf_mcl/render/image.hpp"

namespace tsdf_mcl {

struct PlotSeries {
  std::string label{};                      // shown in the legend; empty = not listed
  std::vector<double> x{};                  // e.g. time in s
  std::vector<double> y{};                  // same length as x; a non-finite value leaves a gap in the line
  std::optional<Rgb> color = std::nullopt;  // default: the next palette colour
  float width = 2.0f;                       // line width in pixels
};

// A horizontal reference line (e.g. the +-0.3 m convergence band), labelled at its right end.
struct HorizontalLine {
  double y = 0.0;
  std::string label{};
  Rgb color = rgb_hex(0x777777);
  bool dashed = true;
};

// A vertical marker at an x value (e.g. the time the filter converged), labelled at its top.
struct VerticalMarker {
  VerticalMarker(double at, std::string text = {}, Rgb colour = rgb_hex(0x333333))
      : x(at), label(std::move(text)), color(colour) {}
  double x;
  std::string label;
  Rgb color;
};

struct LinePlot {
  std::string title;
  std::string x_label = "time [s]";
  std::string y_label;
  std::vector<PlotSeries> series;
  std::vector<HorizontalLine> horizontal_lines;
  std::vector<VerticalMarker> markers;
  // Fixed axis limits; by default the axes cover the data, the reference lines and the markers. Data outside fixed
  // limits is clipped at the plot's border.
  std::optional<double> x_min, x_max, y_min, y_max;
  int width = 1000;  // image size in pixels
  int height = 500;
  float text_scale = 1.5f;  // see TextStyle::scale
};

// Throws Error for series whose x and y differ in length, an image too small for its axes, or empty/inverted fixed
// limits.
Image render_plot(const LinePlot& plot);
// render_plot, then save_png.
void write_plot_png(const LinePlot& plot, const std::filesystem::path& file);

// Axis ticks at a 1-2-5 x 10^k step, the first at or below lo and the last at or above hi, with at most max_ticks
// values (at least 2). lo == hi gives a small range around the value.
struct Ticks {
  std::vector<double> values;
  double step = 1.0;
  int decimals = 0;  // digits after the point that show the step exactly
};
Ticks nice_ticks(double lo, double hi, int max_ticks = 8);
// The tick's text: `decimals` digits, never "-0".
std::string format_tick(double value, int decimals);

}  // namespace tsdf_mcl
