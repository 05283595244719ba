// Figure widgets over Image's public drawing: the top-down world-to-pixel transform, the scale bar and the legend.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/render/image.hpp"

namespace tsdf_mcl {

TopDownTransform::TopDownTransform(const Eigen::Vector2d& world_min, const Eigen::Vector2d& world_max,
                                   double metres_per_pixel, const Margins& margins, const Eigen::Vector2i& origin)
    : world_min_(world_min),
      world_max_(world_max),
      metres_per_pixel_(metres_per_pixel),
      margins_(margins),
      origin_(origin) {
  if (!(metres_per_pixel > 0.0) || !std::isfinite(metres_per_pixel)) {
    throw Error("pixel size must be a positive number of metres");
  }
  if (!world_min.allFinite() || !world_max.allFinite() || (world_max.array() <= world_min.array()).any()) {
    throw Error("view area is empty or not finite");
  }
  const Eigen::Vector2d pixels = ((world_max - world_min) / metres_per_pixel).array().ceil();
  if ((pixels.array() > kMaxImageSide).any()) {
    throw Error("view of " + std::to_string(world_max.x() - world_min.x()) + " x " +
                std::to_string(world_max.y() - world_min.y()) + " m at " + std::to_string(metres_per_pixel) +
                " m per pixel exceeds " + std::to_string(kMaxImageSide) + " pixels: choose a larger pixel size");
  }
  area_width_ = std::max(1, static_cast<int>(pixels.x()));
  area_height_ = std::max(1, static_cast<int>(pixels.y()));
}

Eigen::Vector2f TopDownTransform::to_pixel(const Eigen::Vector2d& world) const {
  const double x = origin_.x() + margins_.left + (world.x() - world_min_.x()) / metres_per_pixel_;
  const double y = origin_.y() + margins_.top + area_height_ - (world.y() - world_min_.y()) / metres_per_pixel_;
  return {static_cast<float>(x), static_cast<float>(y)};
}

Eigen::Vector2d TopDownTransform::to_world(const Eigen::Vector2f& pixel) const {
  const double x = (pixel.x() - origin_.x() - margins_.left) * metres_per_pixel_ + world_min_.x();
  const double y = (origin_.y() + margins_.top + area_height_ - pixel.y()) * metres_per_pixel_ + world_min_.y();
  return {x, y};
}

Eigen::Vector4i TopDownTransform::area() const {
  const int x0 = origin_.x() + margins_.left, y0 = origin_.y() + margins_.top;
  return {x0, y0, x0 + area_width_, y0 + area_height_};
}

TopDownTransform TopDownTransform::moved_to(const Eigen::Vector2i& origin) const {
  TopDownTransform t = *this;
  t.origin_ = origin;
  return t;
}

double nice_number_at_most(double limit) {
  if (!(limit > 0.0) || !std::isfinite(limit)) throw Error("nice_number_at_most needs a positive finite limit");
  const double magnitude = std::pow(10.0, std::floor(std::log10(limit)));
  // Guards against log10 rounding (limit = 1000 giving magnitude 100 or 10000).
  for (const double m : {magnitude * 10.0, magnitude, magnitude / 10.0}) {
    for (const double f : {5.0, 2.0, 1.0}) {
      if (f * m <= limit * (1.0 + 1e-12)) return f * m;
    }
  }
  return magnitude / 10.0;
}

namespace {

std::string format_length(double metres) {
  char text[32];
  if (metres >= 1.0)
    std::snprintf(text, sizeof(text), "%g m", metres);
  else
    std::snprintf(text, sizeof(text), "%g cm", metres * 100.0);
  return text;
}

}  // namespace

void draw_scale_bar(Image& image, const TopDownTransform& view, float x, float y, float max_length_px,
                    float text_scale) {
  const double metres = nice_number_at_most(max_length_px * view.metres_per_pixel());
  const float length = static_cast<float>(metres / view.metres_per_pixel());
  const std::string label = format_length(metres);
  const Eigen::Vector2f label_size = text_size(label, text_scale);
  const float pad = 3.0f * text_scale;
  const float tick = 3.0f * text_scale;
  const float left = std::min(x, x + length / 2.0f - label_size.x() / 2.0f);
  const float right = std::max(x + length, x + length / 2.0f + label_size.x() / 2.0f);
  image.fill_rect(left - pad, y - tick - label_size.y() - 2.0f * pad, right + pad, y + pad, colors::kWhite, 0.8f);
  const float w = std::max(1.0f, text_scale);
  image.fill_rect(x, y - w, x + length, y, colors::kText);
  image.fill_rect(x, y - tick, x + w, y, colors::kText);
  image.fill_rect(x + length - w, y - tick, x + length, y, colors::kText);
  image.draw_text(x + length / 2.0f, y - tick - pad / 2.0f, label,
                  {text_scale, colors::kText, HAlign::kCenter, VAlign::kBottom, false});
}

Eigen::Vector2f draw_colorbar(Image& image, float x, float y, float bar_width,
                              const std::function<Rgb(float)>& colormap, const std::string& lo_label,
                              const std::string& hi_label, const std::string& caption, float text_scale) {
  const float bar_height = 6.0f * text_scale;
  const float gap = 2.0f * text_scale;
  const TextStyle style{text_scale, colors::kText, HAlign::kLeft, VAlign::kTop, false};
  const Eigen::Vector4f caption_box = image.draw_text(x, y, caption, style);
  const float bar_top = caption.empty() ? y : caption_box.w() + gap;
  const int x0 = static_cast<int>(std::round(x)), x1 = static_cast<int>(std::round(x + bar_width));
  for (int px = x0; px < x1; ++px) {
    const float t = x1 - x0 > 1 ? static_cast<float>(px - x0) / static_cast<float>(x1 - x0 - 1) : 0.0f;
    image.fill_rect(static_cast<float>(px), bar_top, static_cast<float>(px + 1), bar_top + bar_height, colormap(t));
  }
  image.stroke_rect(static_cast<float>(x0) - 1.0f, bar_top - 1.0f, static_cast<float>(x1) + 1.0f,
                    bar_top + bar_height + 1.0f, colors::kAxis);
  const float label_top = bar_top + bar_height + gap;
  image.draw_text(x, label_top, lo_label, style);
  const Eigen::Vector4f hi_box = image.draw_text(static_cast<float>(x1), label_top, hi_label,
                                                 {text_scale, colors::kText, HAlign::kRight, VAlign::kTop, false});
  return {std::max(bar_width, caption_box.z() - x), hi_box.w() - y};
}

namespace {

constexpr float kSwatchUnits = 14.0f;  // legend symbol width in font units

}  // namespace

Eigen::Vector2f legend_size(const std::vector<LegendEntry>& entries, float text_scale) {
  if (entries.empty()) return Eigen::Vector2f::Zero();
  float label_width = 0.0f;
  for (const auto& e : entries) label_width = std::max(label_width, text_size(e.label, text_scale).x());
  const float pad = 5.0f * text_scale;
  const float row = 12.0f * text_scale;
  return {pad + kSwatchUnits * text_scale + pad + label_width + pad,
          pad + static_cast<float>(entries.size()) * row - (12.0f - kCapHeight) * text_scale + pad};
}

void draw_legend(Image& image, float x, float y, const std::vector<LegendEntry>& entries, float text_scale) {
  if (entries.empty()) return;
  const Eigen::Vector2f size = legend_size(entries, text_scale);
  const float pad = 5.0f * text_scale;
  const float row = 12.0f * text_scale;
  const float swatch = kSwatchUnits * text_scale;
  image.fill_rect(x, y, x + size.x(), y + size.y(), colors::kWhite, 0.85f);
  image.stroke_rect(x, y, x + size.x(), y + size.y(), colors::kGrid);
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const LegendEntry& e = entries[i];
    const float top = y + pad + static_cast<float>(i) * row;  // of the label's capitals
    const float mid = top + kCapHeight * text_scale / 2.0f;
    const Eigen::Vector2f a(x + pad, mid), b(x + pad + swatch, mid);
    switch (e.symbol) {
      case LegendEntry::Symbol::kLine:
        image.draw_line(a, b, e.color, 1.5f * text_scale);
        break;
      case LegendEntry::Symbol::kDashedLine:
        image.draw_dashed_line(a, b, e.color, text_scale, 2.5f * text_scale);
        break;
      case LegendEntry::Symbol::kDot:
        image.fill_circle((a + b) / 2.0f, 2.5f * text_scale, e.color);
        break;
      case LegendEntry::Symbol::kRing:
        image.stroke_circle((a + b) / 2.0f, 2.5f * text_scale, e.color, 0.8f * text_scale);
        break;
      case LegendEntry::Symbol::kArrow: {
        const float h = kCapHeight * text_scale / 2.0f + 1.0f;
        const Eigen::Vector2f c = (a + b) / 2.0f;
        image.fill_polygon({c + Eigen::Vector2f(1.2f * h, 0.0f), c + Eigen::Vector2f(-h, h),
                            c + Eigen::Vector2f(-0.4f * h, 0.0f), c + Eigen::Vector2f(-h, -h)},
                           e.color);
        break;
      }
      case LegendEntry::Symbol::kBand:
        image.fill_rect(a.x(), top, b.x(), top + kCapHeight * text_scale, e.color);
        image.stroke_rect(a.x(), top, b.x(), top + kCapHeight * text_scale, colors::kAxis);
        break;
    }
    image.draw_text(x + pad + swatch + pad, mid, e.label,
                    {text_scale, colors::kText, HAlign::kLeft, VAlign::kMiddle, false});
  }
}

}  // namespace tsdf_mcl
