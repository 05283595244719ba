#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/render/plot.hpp"

using tsdf_mcl::Error;
using tsdf_mcl::Image;
using tsdf_mcl::LinePlot;
using tsdf_mcl::nice_ticks;
using tsdf_mcl::Rgb;

namespace {

// The step is 1, 2 or 5 times a power of ten.
bool is_nice_step(double step) {
  const double magnitude = std::pow(10.0, std::floor(std::log10(step) + 1e-9));
  const double f = step / magnitude;
  return std::abs(f - 1.0) < 1e-9 || std::abs(f - 2.0) < 1e-9 || std::abs(f - 5.0) < 1e-9;
}

void expect_nice_cover(double lo, double hi, int max_ticks) {
  SCOPED_TRACE(testing::Message() << "[" << lo << ", " << hi << "] max " << max_ticks);
  const tsdf_mcl::Ticks t = nice_ticks(lo, hi, max_ticks);
  ASSERT_GE(t.values.size(), 2u);
  EXPECT_LE(static_cast<int>(t.values.size()), std::max(max_ticks, 2));
  EXPECT_TRUE(is_nice_step(t.step)) << t.step;
  EXPECT_LE(t.values.front(), std::min(lo, hi) + 1e-12 * std::abs(lo));
  EXPECT_GE(t.values.back(), std::max(lo, hi) - 1e-12 * std::abs(hi));
  for (std::size_t i = 1; i < t.values.size(); ++i) {
    EXPECT_NEAR(t.values[i] - t.values[i - 1], t.step, t.step * 1e-9);
  }
  // Every tick is a whole multiple of the step, so the labels are round numbers.
  for (double v : t.values) EXPECT_NEAR(v / t.step, std::round(v / t.step), 1e-6);
  // Labels with the chosen number of decimals tell the ticks apart.
  for (std::size_t i = 1; i < t.values.size(); ++i) {
    EXPECT_NE(tsdf_mcl::format_tick(t.values[i], t.decimals), tsdf_mcl::format_tick(t.values[i - 1], t.decimals));
  }
}

int count_color(const Image& image, Rgb color) {
  int n = 0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) n += image.at(x, y) == color;
  }
  return n;
}

// Pixels that are `color` drawn over white with at least half coverage (anti-aliased edges of a line).
int count_mostly(const Image& image, Rgb color) {
  int n = 0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const Rgb p = image.at(x, y);
      const float coverage = static_cast<float>(255 - p.r + 255 - p.g + 255 - p.b) /
                             static_cast<float>(255 - color.r + 255 - color.g + 255 - color.b);
      n += coverage >= 0.5f && tsdf_mcl::mix(tsdf_mcl::colors::kWhite, color, coverage) == p;
    }
  }
  return n;
}

}  // namespace

TEST(PlotTicks, KnownRanges) {
  auto t = nice_ticks(0.0, 87.0, 9);
  EXPECT_DOUBLE_EQ(t.step, 20.0);
  EXPECT_DOUBLE_EQ(t.values.front(), 0.0);
  EXPECT_DOUBLE_EQ(t.values.back(), 100.0);
  EXPECT_EQ(t.decimals, 0);

  t = nice_ticks(-0.27, 0.31, 8);
  EXPECT_DOUBLE_EQ(t.step, 0.1);
  EXPECT_NEAR(t.values.front(), -0.3, 1e-12);
  EXPECT_NEAR(t.values.back(), 0.4, 1e-12);
  EXPECT_EQ(t.decimals, 1);

  t = nice_ticks(0.0, 1.0, 3);
  EXPECT_DOUBLE_EQ(t.step, 0.5);
  EXPECT_EQ(t.values.size(), 3u);
}

TEST(PlotTicks, AreNiceAndCoverAnyRange) {
  expect_nice_cover(0.0, 87.0, 9);
  expect_nice_cover(-6.1, 3.7, 8);
  expect_nice_cover(1e-6, 3e-6, 6);
  expect_nice_cover(1234567.0, 1234999.0, 7);
  expect_nice_cover(-1e6, 1e6, 5);
  expect_nice_cover(0.049, 0.051, 10);
  expect_nice_cover(5.0, -5.0, 4);  // inverted
  expect_nice_cover(3.0, 3.0, 5);   // degenerate: padded around the value
  expect_nice_cover(0.0, 0.0, 5);
  expect_nice_cover(0.0, 1.0, 1);  // at least two ticks
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> exponent(-5.0, 5.0), unit(-1.0, 1.0);
  for (int i = 0; i < 300; ++i) {
    const double scale = std::pow(10.0, exponent(rng));
    const double a = unit(rng) * scale, b = unit(rng) * scale;
    expect_nice_cover(a, b, 3 + i % 9);
  }
  EXPECT_THROW(nice_ticks(0.0, std::numeric_limits<double>::infinity()), Error);
  EXPECT_THROW(nice_ticks(std::numeric_limits<double>::quiet_NaN(), 1.0), Error);
}

TEST(PlotTicks, LabelsAreRoundAndNeverNegativeZero) {
  EXPECT_EQ(tsdf_mcl::format_tick(-0.0, 1), "0.0");
  EXPECT_EQ(tsdf_mcl::format_tick(-1e-17, 2), "0.00");
  EXPECT_EQ(tsdf_mcl::format_tick(0.30000000000000004, 1), "0.3");
  EXPECT_EQ(tsdf_mcl::format_tick(-2.0, 0), "-2");
  EXPECT_EQ(tsdf_mcl::format_tick(1500.0, 0), "1500");
}

TEST(PlotChart, DrawsSeriesReferenceLinesAndLegend) {
  LinePlot plot;
  plot.title = "translation error";
  plot.y_label = "error [m]";
  const Rgb x_color{31, 119, 180}, marker_color{200, 0, 200}, band_color{0, 150, 0};
  tsdf_mcl::PlotSeries x{"x", {}, {}, x_color};
  tsdf_mcl::PlotSeries y{"y", {}, {}};
  for (int i = 0; i < 100; ++i) {
    const double t = 0.1 * i;
    x.x.push_back(t);
    x.y.push_back(i < 20 ? 3.0 * std::sin(t * 5.0) : 0.05 * std::sin(t * 9.0));
    y.x.push_back(t);
    y.y.push_back(i == 50 ? std::numeric_limits<double>::quiet_NaN() : 0.1 * std::cos(t));
  }
  plot.series = {x, y};
  plot.horizontal_lines = {{0.3, "+0.3 m", band_color}, {-0.3, "-0.3 m", band_color}};
  plot.markers.emplace_back(2.0, "converged", marker_color);
  const Image image = tsdf_mcl::render_plot(plot);
  EXPECT_EQ(image.width(), 1000);
  EXPECT_EQ(image.height(), 500);
  EXPECT_GT(count_color(image, x_color), 300);
  EXPECT_GT(count_color(image, tsdf_mcl::palette_color(1)), 300);  // the second series' default colour
  EXPECT_GT(count_color(image, band_color), 100);
  // The marker's 1.5-pixel dashes fall between pixel columns: they show as pixels mostly covered in its colour.
  EXPECT_GT(count_mostly(image, marker_color), 100);

  // The legend sits right of the plot area: series colours appear in the rightmost tenth of the image.
  int legend_ink = 0;
  for (int py = 0; py < image.height(); ++py) {
    for (int px = image.width() * 9 / 10; px < image.width(); ++px) legend_ink += image.at(px, py) == x_color;
  }
  EXPECT_GT(legend_ink, 5);
}

TEST(PlotChart, FixedLimitsClipTheDataAndCustomSizesWork) {
  LinePlot plot;
  plot.width = 420;
  plot.height = 260;
  plot.y_min = -1.0;
  plot.y_max = 1.0;
  const Rgb color{250, 0, 0};
  plot.series = {{"wild", {0.0, 1.0, 2.0, 3.0}, {0.0, 1e30, -1e30, 0.5}, color}};
  const Image image = tsdf_mcl::render_plot(plot);
  EXPECT_EQ(image.width(), 420);
  EXPECT_EQ(image.height(), 260);
  EXPECT_GT(count_color(image, color), 20);
  // Nothing of the series is drawn above the plot area's top (the title-less top margin) or in the tick labels.
  for (int px = 0; px < image.width(); ++px) {
    EXPECT_NE(image.at(px, 2), color);
    EXPECT_NE(image.at(px, image.height() - 3), color);
  }
}

TEST(PlotChart, EmptyAndDegenerateInputsStillDraw) {
  LinePlot plot;
  EXPECT_NO_THROW(tsdf_mcl::render_plot(plot));
  plot.series = {{"one point", {5.0}, {1.0}, Rgb{0, 0, 250}}};
  const Image image = tsdf_mcl::render_plot(plot);
  EXPECT_GT(count_color(image, Rgb{0, 0, 250}), 5);  // drawn as a dot
  plot.series = {{"flat", {0.0, 1.0, 2.0}, {2.0, 2.0, 2.0}}};
  EXPECT_NO_THROW(tsdf_mcl::render_plot(plot));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  plot.series = {{"all gaps", {nan, nan}, {nan, 1.0}}};
  EXPECT_NO_THROW(tsdf_mcl::render_plot(plot));
}

TEST(PlotChart, BadInputThrows) {
  LinePlot plot;
  plot.series = {{"bad", {0.0, 1.0}, {1.0}}};
  EXPECT_THROW(tsdf_mcl::render_plot(plot), Error);
  plot.series.clear();
  plot.width = 60;
  EXPECT_THROW(tsdf_mcl::render_plot(plot), Error);
  plot.width = 1000;
  plot.y_min = 1.0;
  plot.y_max = 1.0;
  EXPECT_THROW(tsdf_mcl::render_plot(plot), Error);
  plot.y_max = std::numeric_limits<double>::infinity();
  EXPECT_THROW(tsdf_mcl::render_plot(plot), Error);
}

TEST(PlotChart, WritesPngFiles) {
  tsdf_mcl::test::TempDir dir;
  LinePlot plot;
  plot.width = 300;
  plot.height = 200;
  plot.series = {{"a", {0.0, 1.0}, {0.0, 1.0}}};
  tsdf_mcl::write_plot_png(plot, dir / "p.png");
  const Image back = tsdf_mcl::load_png(dir / "p.png");
  EXPECT_EQ(back.width(), 300);
  EXPECT_EQ(back.height(), 200);
  EXPECT_THROW(tsdf_mcl::write_plot_png(plot, dir / "missing/p.png"), Error);
}
