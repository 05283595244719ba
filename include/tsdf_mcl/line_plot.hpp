#pragma once
// A small line-plot writer (PNG through stb_image_write) for evaluation figures: axes with "nice" ticks and
// numbers, grid, one coloured polyline per series, a legend, optional vertical markers. Text uses a built-in
// 5x7 pixel font (digits, lower-case letters and a few symbols; upper case is drawn as lower case).
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace tsdf_mcl {

using Rgb = std::array<std::uint8_t, 3>;

struct PlotSeries {
  std::string label;
  Rgb color{0, 0, 0};
  std::vector<double> x;
  std::vector<double> y;  // same length as x; non-finite values break the line
};

struct LinePlot {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<PlotSeries> series;
  std::vector<std::pair<double, std::string>> markers;  // dashed vertical lines at x, with a label
  std::optional<std::pair<double, double>> y_range;     // default: the data's range (with 0 included)
  int width = 1000;
  int height = 520;
};

// Throws Error if the file cannot be written or the plot has no finite data.
void write_plot_png(const LinePlot& plot, const std::filesystem::path& file);
// Several plots of the same width stacked top to bottom in one image.
void write_plots_png(const std::vector<LinePlot>& plots, const std::filesystem::path& file);

// The rendered image (RGB, row-major, width*height*3 bytes), for tests.
std::vector<std::uint8_t> render_plot(const LinePlot& plot);

// Tick positions for [lo, hi]: multiples of 1, 2 or 5 x 10^k, about `target` of them.
std::vector<double> nice_ticks(double lo, double hi, int target = 6);

}  // namespace tsdf_mcl
