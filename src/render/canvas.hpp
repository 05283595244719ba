#pragma once
// Drawing into an Image with Cairo (private to src/render/): Cairo's view of the image's pixels (detail::ImageAccess)
// and a Canvas per drawing operation. Used by image.cpp (the drawing) and png_io.cpp (PNG files).
#include <cairo.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>

#include "tsdf_mcl/core/checked_math.hpp"
#include "tsdf_mcl/render/image.hpp"

namespace tsdf_mcl {

// Cairo draws on an image's 0x00RRGGBB copy of its pixels; every change is copied into the RGB rows at once.
struct detail::ImageAccess {
  static std::uint32_t* xrgb(Image& image, int x, int y) {
    return image.xrgb_.data() + static_cast<std::size_t>(y) * image.width_ + x;
  }
  static const std::uint32_t* xrgb(const Image& image) { return image.xrgb_.data(); }
  static Eigen::Vector4i clip(const Image& image) {
    return {image.clip_x0_, image.clip_y0_, image.clip_x1_, image.clip_y1_};
  }
  // Copies the 0x00RRGGBB pixels x0 <= x < x1, y0 <= y < y1 into the RGB rows.
  static void sync(Image& image, int x0, int y0, int x1, int y1) {
    for (int y = y0; y < y1; ++y) {
      const std::size_t row = static_cast<std::size_t>(y) * image.width_;
      for (std::size_t i = row + x0; i < row + x1; ++i) {
        const std::uint32_t p = image.xrgb_[i];
        image.pixels_[3 * i] = static_cast<std::uint8_t>(p >> 16);
        image.pixels_[3 * i + 1] = static_cast<std::uint8_t>(p >> 8);
        image.pixels_[3 * i + 2] = static_cast<std::uint8_t>(p);
      }
    }
  }
};

namespace render {

inline float clamp01(float v) { return v > 0.0f ? std::min(v, 1.0f) : 0.0f; }  // NaN gives 0

// One drawing operation: a Cairo context over the part of the image that the operation may touch (its bounds,
// within the clip rectangle), in image pixel coordinates. Cairo cannot draw outside that part, which is copied into
// the image's RGB rows when the operation ends, so the two copies of the pixels always agree.
class Canvas {
 public:
  Canvas(Image& image, const Eigen::AlignedBox2d& bounds) : image_(image) {
    if (image.empty() || !(bounds.min().array() <= bounds.max().array()).all()) return;  // empty or NaN
    const Eigen::Vector4i clip = detail::ImageAccess::clip(image);
    x0_ = std::max(clip[0], io::saturated_floor(bounds.min().x()));
    y0_ = std::max(clip[1], io::saturated_floor(bounds.min().y()));
    x1_ = std::min(clip[2], io::saturated_ceil(bounds.max().x()));
    y1_ = std::min(clip[3], io::saturated_ceil(bounds.max().y()));
    if (x1_ <= x0_ || y1_ <= y0_) return;
    // A surface over just this part keeps Cairo's device coordinates small and its work within the part.
    surface_ = cairo_image_surface_create_for_data(
        reinterpret_cast<unsigned char*>(detail::ImageAccess::xrgb(image, x0_, y0_)), CAIRO_FORMAT_RGB24, x1_ - x0_,
        y1_ - y0_, image.width() * 4);
    cr_ = cairo_create(surface_);
    cairo_translate(cr_, -x0_, -y0_);
  }
  Canvas(const Canvas&) = delete;
  Canvas& operator=(const Canvas&) = delete;
  ~Canvas() {
    if (!cr_) return;
    cairo_destroy(cr_);
    cairo_surface_destroy(surface_);
    detail::ImageAccess::sync(image_, x0_, y0_, x1_, y1_);
  }

  explicit operator bool() const { return cr_ != nullptr; }
  cairo_t* cr() const { return cr_; }
  // The part grown by margin pixels: coordinates are clipped to it, so shapes cut there end out of sight.
  Eigen::AlignedBox2d guard(double margin) const {
    return Eigen::AlignedBox2d(Eigen::Vector2d(x0_ - margin, y0_ - margin),
                               Eigen::Vector2d(x1_ + margin, y1_ + margin));
  }
  void set_color(Rgb color, float alpha) const {
    cairo_set_source_rgba(cr_, color.r / 255.0, color.g / 255.0, color.b / 255.0, clamp01(alpha));
  }

 private:
  Image& image_;
  int x0_ = 0, y0_ = 0, x1_ = 0, y1_ = 0;
  cairo_surface_t* surface_ = nullptr;
  cairo_t* cr_ = nullptr;
};

}  // namespace render
}  // namespace tsdf_mcl
