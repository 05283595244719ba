#include "tsdf_mcl/image.hpp"

#include <stb_easy_font.h>
#include <stb_image.h>
#include <stb_image_write.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl {
namespace {

constexpr int kMaxImageSide = 32768;

float clamp01(float v) { return std::clamp(v, 0.0f, 1.0f); }

float distance_to_segment(const Eigen::Vector2f& p, const Eigen::Vector2f& a, const Eigen::Vector2f& b) {
  const Eigen::Vector2f ab = b - a;
  const float len2 = ab.squaredNorm();
  const float t = len2 > 0.0f ? std::clamp((p - a).dot(ab) / len2, 0.0f, 1.0f) : 0.0f;
  return (p - (a + t * ab)).norm();
}

// Per-pixel coverage of one shape over its bounding box, merged by maximum and blended once: overlapping parts of a
// shape (polyline joints, the strokes of a glyph) would otherwise be composited twice and show as darker spots.
class CoverageMask {
 public:
  CoverageMask(const Image& image, float x0, float y0, float x1, float y1) {
    x0_ = std::max(0, static_cast<int>(std::floor(x0)));
    y0_ = std::max(0, static_cast<int>(std::floor(y0)));
    x1_ = std::min(image.width(), static_cast<int>(std::ceil(x1)));
    y1_ = std::min(image.height(), static_cast<int>(std::ceil(y1)));
    if (x1_ > x0_ && y1_ > y0_) coverage_.assign(static_cast<std::size_t>(x1_ - x0_) * (y1_ - y0_), 0.0f);
  }

  int x0() const { return x0_; }
  int y0() const { return y0_; }
  int x1() const { return x1_; }
  int y1() const { return y1_; }

  void add(int x, int y, float c) {
    if (x < x0_ || x >= x1_ || y < y0_ || y >= y1_ || c <= 0.0f) return;
    float& cell = coverage_[static_cast<std::size_t>(y - y0_) * (x1_ - x0_) + (x - x0_)];
    cell = std::max(cell, std::min(c, 1.0f));
  }

  void add_capsule(const Eigen::Vector2f& a, const Eigen::Vector2f& b, float radius) {
    const int xa = std::max(x0_, static_cast<int>(std::floor(std::min(a.x(), b.x()) - radius - 1.0f)));
    const int xb = std::min(x1_, static_cast<int>(std::ceil(std::max(a.x(), b.x()) + radius + 1.0f)));
    const int ya = std::max(y0_, static_cast<int>(std::floor(std::min(a.y(), b.y()) - radius - 1.0f)));
    const int yb = std::min(y1_, static_cast<int>(std::ceil(std::max(a.y(), b.y()) + radius + 1.0f)));
    for (int y = ya; y < yb; ++y) {
      for (int x = xa; x < xb; ++x) {
        const Eigen::Vector2f p(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
        add(x, y, radius + 0.5f - distance_to_segment(p, a, b));
      }
    }
  }

  void add_rect(float x0, float y0, float x1, float y1) {
    const int xa = std::max(x0_, static_cast<int>(std::floor(x0)));
    const int xb = std::min(x1_, static_cast<int>(std::ceil(x1)));
    const int ya = std::max(y0_, static_cast<int>(std::floor(y0)));
    const int yb = std::min(y1_, static_cast<int>(std::ceil(y1)));
    for (int y = ya; y < yb; ++y) {
      const float cy = clamp01(std::min(static_cast<float>(y + 1), y1) - std::max(static_cast<float>(y), y0));
      for (int x = xa; x < xb; ++x) {
        const float cx = clamp01(std::min(static_cast<float>(x + 1), x1) - std::max(static_cast<float>(x), x0));
        add(x, y, cx * cy);
      }
    }
  }

  void blend_into(Image& image, Rgb color, float alpha) const {
    if (coverage_.empty()) return;
    for (int y = y0_; y < y1_; ++y) {
      for (int x = x0_; x < x1_; ++x) {
        const float c = coverage_[static_cast<std::size_t>(y - y0_) * (x1_ - x0_) + (x - x0_)];
        if (c > 0.0f) image.blend_pixel(x, y, color, c * alpha);
      }
    }
  }

 private:
  int x0_ = 0, y0_ = 0, x1_ = 0, y1_ = 0;
  std::vector<float> coverage_;
};

// A mask over the bounding box of a polyline's finite points, grown by the stroke radius (plus a pixel of
// anti-aliasing).
CoverageMask mask_around(const Image& image, const std::vector<Eigen::Vector2f>& points, float r) {
  Eigen::Vector2f lo = points.front(), hi = points.front();
  for (const auto& p : points) {
    if (!p.allFinite()) continue;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return CoverageMask(image, lo.x() - r - 1.0f, lo.y() - r - 1.0f, hi.x() + r + 1.0f, hi.y() + r + 1.0f);
}

// Lines thinner than a pixel are drawn one pixel wide and correspondingly fainter, which keeps their apparent
// weight and avoids broken, aliased hairlines.
void thin_line_compensation(float& width, float& alpha) {
  if (width < 1.0f) {
    alpha *= std::max(width, 0.0f);
    width = 1.0f;
  }
}

std::string printable(const std::string& text) {
  std::string out = text;
  for (char& c : out) {
    if (c != '\n' && (c < 32 || c > 126)) c = '?';
  }
  return out;
}

// stb_easy_font geometry: capitals span 7 units below the pen's y, descenders 2 more, lines are 12 apart and every
// glyph's advance leaves 2 units of space after it.
constexpr float kCapHeight = 7.0f;
constexpr float kDescender = 2.0f;
constexpr float kLineAdvance = 12.0f;
constexpr float kTrailingSpace = 2.0f;

int line_count(const std::string& text) { return 1 + static_cast<int>(std::count(text.begin(), text.end(), '\n')); }

Eigen::Vector2f font_units_size(std::string& text) {
  if (text.empty()) return Eigen::Vector2f::Zero();
  const float width = std::max(0.0f, static_cast<float>(stb_easy_font_width(text.data())) - kTrailingSpace);
  const float height = static_cast<float>(line_count(text) - 1) * kLineAdvance + kCapHeight + kDescender;
  return {width, height};
}

}  // namespace

Rgb mix(Rgb a, Rgb b, float t) {
  t = clamp01(t);
  auto channel = [t](std::uint8_t u, std::uint8_t v) {
    return static_cast<std::uint8_t>(std::lround(static_cast<float>(u) + t * (static_cast<float>(v) - u)));
  };
  return {channel(a.r, b.r), channel(a.g, b.g), channel(a.b, b.b)};
}

Rgb viridis(float t) {
  // matplotlib's viridis sampled at eleven evenly spaced points; linear interpolation between them stays within a
  // few levels of the full 256-entry table.
  static constexpr std::array<Rgb, 11> kStops = {
      rgb_hex(0x440154), rgb_hex(0x482475), rgb_hex(0x414487), rgb_hex(0x355f8d), rgb_hex(0x2a788e), rgb_hex(0x21918c),
      rgb_hex(0x22a884), rgb_hex(0x44bf70), rgb_hex(0x7ad151), rgb_hex(0xbddf26), rgb_hex(0xfde725)};
  if (!std::isfinite(t)) t = 0.0f;
  const float s = clamp01(t) * static_cast<float>(kStops.size() - 1);
  const auto i = std::min(static_cast<std::size_t>(s), kStops.size() - 2);
  return mix(kStops[i], kStops[i + 1], s - static_cast<float>(i));
}

Rgb palette_color(std::size_t i) {
  static constexpr std::array<Rgb, 10> kTab10 = {rgb_hex(0x1f77b4), rgb_hex(0xff7f0e), rgb_hex(0x2ca02c),
                                                 rgb_hex(0xd62728), rgb_hex(0x9467bd), rgb_hex(0x8c564b),
                                                 rgb_hex(0xe377c2), rgb_hex(0x7f7f7f), rgb_hex(0xbcbd22),
                                                 rgb_hex(0x17becf)};
  return kTab10[i % kTab10.size()];
}

Image::Image(int width, int height, Rgb background) {
  if (width < 1 || height < 1 || width > kMaxImageSide || height > kMaxImageSide) {
    throw Error("image size " + std::to_string(width) + " x " + std::to_string(height) + " out of range (1.." +
                std::to_string(kMaxImageSide) + " pixels per side)");
  }
  width_ = width;
  height_ = height;
  pixels_.resize(static_cast<std::size_t>(width) * height * 3);
  reset_clip();
  fill(background);
}

Rgb Image::at(int x, int y) const {
  if (x < 0 || y < 0 || x >= width_ || y >= height_) {
    throw Error("pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") outside a " + std::to_string(width_) +
                " x " + std::to_string(height_) + " image");
  }
  const std::size_t i = (static_cast<std::size_t>(y) * width_ + x) * 3;
  return {pixels_[i], pixels_[i + 1], pixels_[i + 2]};
}

void Image::set_clip(int x0, int y0, int x1, int y1) {
  clip_x0_ = std::clamp(x0, 0, width_);
  clip_y0_ = std::clamp(y0, 0, height_);
  clip_x1_ = std::clamp(x1, clip_x0_, width_);
  clip_y1_ = std::clamp(y1, clip_y0_, height_);
}

void Image::reset_clip() { set_clip(0, 0, width_, height_); }

void Image::set_pixel(int x, int y, Rgb color) {
  if (x < clip_x0_ || x >= clip_x1_ || y < clip_y0_ || y >= clip_y1_) return;
  const std::size_t i = (static_cast<std::size_t>(y) * width_ + x) * 3;
  pixels_[i] = color.r;
  pixels_[i + 1] = color.g;
  pixels_[i + 2] = color.b;
}

void Image::blend_pixel(int x, int y, Rgb color, float alpha) {
  if (x < clip_x0_ || x >= clip_x1_ || y < clip_y0_ || y >= clip_y1_ || !(alpha > 0.0f)) return;
  const std::size_t i = (static_cast<std::size_t>(y) * width_ + x) * 3;
  const Rgb blended = mix({pixels_[i], pixels_[i + 1], pixels_[i + 2]}, color, alpha);
  pixels_[i] = blended.r;
  pixels_[i + 1] = blended.g;
  pixels_[i + 2] = blended.b;
}

void Image::fill(Rgb color) {
  for (int y = clip_y0_; y < clip_y1_; ++y) {
    for (int x = clip_x0_; x < clip_x1_; ++x) set_pixel(x, y, color);
  }
}

void Image::fill_rect(float x0, float y0, float x1, float y1, Rgb color, float alpha) {
  if (x1 < x0) std::swap(x0, x1);
  if (y1 < y0) std::swap(y0, y1);
  CoverageMask mask(*this, x0, y0, x1, y1);
  mask.add_rect(x0, y0, x1, y1);
  mask.blend_into(*this, color, alpha);
}

void Image::stroke_rect(float x0, float y0, float x1, float y1, Rgb color, float width) {
  if (x1 < x0) std::swap(x0, x1);
  if (y1 < y0) std::swap(y0, y1);
  width = std::min({width, (x1 - x0) / 2.0f, (y1 - y0) / 2.0f});
  CoverageMask mask(*this, x0, y0, x1, y1);
  mask.add_rect(x0, y0, x1, y0 + width);
  mask.add_rect(x0, y1 - width, x1, y1);
  mask.add_rect(x0, y0, x0 + width, y1);
  mask.add_rect(x1 - width, y0, x1, y1);
  mask.blend_into(*this, color, 1.0f);
}

void Image::draw_line(const Eigen::Vector2f& a, const Eigen::Vector2f& b, Rgb color, float width, float alpha) {
  draw_polyline({a, b}, color, width, alpha);
}

void Image::draw_polyline(const std::vector<Eigen::Vector2f>& points, Rgb color, float width, float alpha) {
  if (points.empty() || empty()) return;
  thin_line_compensation(width, alpha);
  const float r = width / 2.0f;
  CoverageMask mask = mask_around(*this, points, r);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2f& a = points[i];
    const Eigen::Vector2f& b = i + 1 < points.size() ? points[i + 1] : points[i];
    if (a.allFinite() && b.allFinite()) mask.add_capsule(a, b, r);
  }
  mask.blend_into(*this, color, alpha);
}

void Image::draw_dashed_line(const Eigen::Vector2f& a, const Eigen::Vector2f& b, Rgb color, float width,
                             float dash_length, float alpha) {
  draw_dashed_polyline({a, b}, color, width, dash_length, alpha);
}

void Image::draw_dashed_polyline(const std::vector<Eigen::Vector2f>& points, Rgb color, float width,
                                 float dash_length, float alpha) {
  if (points.empty() || empty()) return;
  if (!(dash_length > 0.0f)) {
    draw_polyline(points, color, width, alpha);
    return;
  }
  thin_line_compensation(width, alpha);
  const float r = width / 2.0f;
  CoverageMask mask = mask_around(*this, points, r);
  // Round caps add r at both ends of a dash; shortening the dash by them keeps dash and gap visibly equal.
  const float cap = std::min(r, dash_length / 4.0f);
  float phase = 0.0f;  // arc length since the start of the current dash-gap period
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {
    const Eigen::Vector2f& a = points[i];
    const Eigen::Vector2f& b = points[i + 1];
    if (!a.allFinite() || !b.allFinite()) continue;
    const float length = (b - a).norm();
    if (length <= 0.0f) continue;
    const Eigen::Vector2f dir = (b - a) / length;
    float s = 0.0f;
    while (s < length) {
      const bool in_dash = phase < dash_length;
      const float step = std::min(length - s, (in_dash ? dash_length : 2.0f * dash_length) - phase);
      if (in_dash) {
        const float dash_start = s - phase, dash_end = dash_start + dash_length;
        const float from = std::max(s, dash_start + cap), to = std::min(s + step, dash_end - cap);
        if (to >= from) mask.add_capsule(a + dir * from, a + dir * to, r);
      }
      s += step;
      phase += step;
      if (phase >= 2.0f * dash_length) phase = 0.0f;
    }
  }
  mask.blend_into(*this, color, alpha);
}

void Image::fill_circle(const Eigen::Vector2f& center, float radius, Rgb color, float alpha) {
  if (empty() || !center.allFinite() || !(radius > 0.0f)) return;
  // A disc smaller than a pixel keeps its area as opacity instead of vanishing between pixel centres.
  if (radius < 0.5f) {
    alpha *= (radius / 0.5f) * (radius / 0.5f);
    radius = 0.5f;
  }
  const int x0 = static_cast<int>(std::floor(center.x() - radius - 1.0f));
  const int x1 = static_cast<int>(std::ceil(center.x() + radius + 1.0f));
  const int y0 = static_cast<int>(std::floor(center.y() - radius - 1.0f));
  const int y1 = static_cast<int>(std::ceil(center.y() + radius + 1.0f));
  for (int y = std::max(y0, clip_y0_); y < std::min(y1, clip_y1_); ++y) {
    for (int x = std::max(x0, clip_x0_); x < std::min(x1, clip_x1_); ++x) {
      const float d = (Eigen::Vector2f(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f) - center).norm();
      const float c = clamp01(radius + 0.5f - d);
      if (c > 0.0f) blend_pixel(x, y, color, c * alpha);
    }
  }
}

void Image::stroke_circle(const Eigen::Vector2f& center, float radius, Rgb color, float width, float alpha) {
  if (empty() || !center.allFinite() || !(radius > 0.0f)) return;
  thin_line_compensation(width, alpha);
  const float reach = radius + width / 2.0f + 1.0f;
  for (int y = std::max(static_cast<int>(std::floor(center.y() - reach)), clip_y0_);
       y < std::min(static_cast<int>(std::ceil(center.y() + reach)), clip_y1_); ++y) {
    for (int x = std::max(static_cast<int>(std::floor(center.x() - reach)), clip_x0_);
         x < std::min(static_cast<int>(std::ceil(center.x() + reach)), clip_x1_); ++x) {
      const float d = (Eigen::Vector2f(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f) - center).norm();
      const float c = clamp01(width / 2.0f + 0.5f - std::abs(d - radius));
      if (c > 0.0f) blend_pixel(x, y, color, c * alpha);
    }
  }
}

void Image::fill_polygon(const std::vector<Eigen::Vector2f>& points, Rgb color, float alpha) {
  if (points.size() < 3 || empty()) return;
  for (const auto& p : points) {
    if (!p.allFinite()) return;
  }
  Eigen::Vector2f lo = points.front(), hi = points.front();
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  auto inside = [&points](float px, float py) {
    bool in = false;
    for (std::size_t i = 0, j = points.size() - 1; i < points.size(); j = i++) {
      const Eigen::Vector2f& a = points[i];
      const Eigen::Vector2f& b = points[j];
      if ((a.y() > py) != (b.y() > py) && px < (b.x() - a.x()) * (py - a.y()) / (b.y() - a.y()) + a.x()) in = !in;
    }
    return in;
  };
  constexpr int kSamples = 4;
  for (int y = std::max(static_cast<int>(std::floor(lo.y())), clip_y0_);
       y < std::min(static_cast<int>(std::ceil(hi.y())), clip_y1_); ++y) {
    for (int x = std::max(static_cast<int>(std::floor(lo.x())), clip_x0_);
         x < std::min(static_cast<int>(std::ceil(hi.x())), clip_x1_); ++x) {
      int hits = 0;
      for (int sy = 0; sy < kSamples; ++sy) {
        for (int sx = 0; sx < kSamples; ++sx) {
          hits += inside(static_cast<float>(x) + (static_cast<float>(sx) + 0.5f) / kSamples,
                         static_cast<float>(y) + (static_cast<float>(sy) + 0.5f) / kSamples);
        }
      }
      if (hits > 0) blend_pixel(x, y, color, alpha * static_cast<float>(hits) / (kSamples * kSamples));
    }
  }
}

Eigen::Vector2f text_size(const std::string& text, float scale) {
  std::string t = printable(text);
  return font_units_size(t) * scale;
}

Eigen::Vector4f Image::draw_text(float x, float y, const std::string& text, const TextStyle& style) {
  std::string t = printable(text);
  const Eigen::Vector2f size = font_units_size(t) * style.scale;
  // The anchor aligns the block of capitals; descenders hang below a bottom- or middle-aligned line as in print.
  const float caps = (static_cast<float>(line_count(t) - 1) * kLineAdvance + kCapHeight) * style.scale;
  float along = 0.0f;  // offset of the text's start along its reading direction
  float across = 0.0f;  // offset of its top across it
  if (style.h_align == HAlign::kCenter) along = -size.x() / 2.0f;
  if (style.h_align == HAlign::kRight) along = -size.x();
  if (style.v_align == VAlign::kMiddle) across = -caps / 2.0f;
  if (style.v_align == VAlign::kBottom) across = -caps;
  // Glyph point (u, v) in text space (u along the text, v down across it) to image pixels.
  auto place = [&](float u, float v) -> Eigen::Vector2f {
    if (style.vertical) return {x + across + v, y - along - u};
    return {x + along + u, y + across + v};
  };
  const Eigen::Vector2f corner_a = place(0.0f, 0.0f), corner_b = place(size.x(), size.y());
  const Eigen::Vector4f box(std::min(corner_a.x(), corner_b.x()), std::min(corner_a.y(), corner_b.y()),
                            std::max(corner_a.x(), corner_b.x()), std::max(corner_a.y(), corner_b.y()));
  if (t.empty() || empty() || !(style.scale > 0.0f)) return box;

  // stb_easy_font emits at most a few dozen quads of 64 bytes per glyph.
  std::vector<char> vertices(t.size() * 64 * 40 + 64);
  const int quads = stb_easy_font_print(0.0f, 0.0f, t.data(), nullptr, vertices.data(), static_cast<int>(vertices.size()));
  CoverageMask mask(*this, box.x() - 1.0f, box.y() - 1.0f, box.z() + 1.0f, box.w() + 1.0f);
  for (int q = 0; q < quads; ++q) {
    float u0, v0, u1, v1;
    std::memcpy(&u0, &vertices[static_cast<std::size_t>(q) * 64], sizeof(float));
    std::memcpy(&v0, &vertices[static_cast<std::size_t>(q) * 64 + 4], sizeof(float));
    std::memcpy(&u1, &vertices[static_cast<std::size_t>(q) * 64 + 32], sizeof(float));  // third vertex: far corner
    std::memcpy(&v1, &vertices[static_cast<std::size_t>(q) * 64 + 36], sizeof(float));
    const Eigen::Vector2f a = place(u0 * style.scale, v0 * style.scale);
    const Eigen::Vector2f b = place(u1 * style.scale, v1 * style.scale);
    mask.add_rect(std::min(a.x(), b.x()), std::min(a.y(), b.y()), std::max(a.x(), b.x()), std::max(a.y(), b.y()));
  }
  mask.blend_into(*this, style.color, 1.0f);
  return box;
}

void Image::blit(const Image& source, int x, int y) {
  for (int sy = 0; sy < source.height(); ++sy) {
    for (int sx = 0; sx < source.width(); ++sx) set_pixel(x + sx, y + sy, source.at(sx, sy));
  }
}

Image compose_grid(const std::vector<Image>& images, int columns, int gap, Rgb background) {
  if (images.empty()) throw Error("nothing to compose: no images");
  columns = std::clamp(columns, 1, static_cast<int>(images.size()));
  gap = std::max(gap, 0);
  int cell_w = 0, cell_h = 0;
  for (const Image& im : images) {
    cell_w = std::max(cell_w, im.width());
    cell_h = std::max(cell_h, im.height());
  }
  const int rows = (static_cast<int>(images.size()) + columns - 1) / columns;
  Image out(columns * cell_w + (columns - 1) * gap, rows * cell_h + (rows - 1) * gap, background);
  for (std::size_t i = 0; i < images.size(); ++i) {
    const int c = static_cast<int>(i) % columns, r = static_cast<int>(i) / columns;
    out.blit(images[i], c * (cell_w + gap), r * (cell_h + gap));
  }
  return out;
}

void save_png(const Image& image, const std::filesystem::path& file) {
  if (image.empty()) throw Error("cannot write image " + file.string() + ": the image is empty");
  std::string encoded;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<std::size_t>(size));
  };
  if (!stbi_write_png_to_func(append, &encoded, image.width(), image.height(), 3, image.pixels().data(),
                              image.width() * 3)) {
    throw Error("cannot write image " + file.string() + ": PNG encoding failed");
  }
  std::error_code ec;
  const auto parent = file.parent_path();
  if (!parent.empty() && !std::filesystem::is_directory(parent, ec)) {
    throw Error("cannot write image " + file.string() + ": folder " + parent.string() + " does not exist");
  }
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw Error("cannot write image " + file.string() + ": " + std::strerror(errno));
  out.write(encoded.data(), static_cast<std::streamsize>(encoded.size()));
  out.close();
  if (!out) throw Error("cannot write image " + file.string() + " (disk full?)");
}

Image load_png(const std::filesystem::path& file) {
  int w = 0, h = 0, channels = 0;
  stbi_uc* data = stbi_load(file.string().c_str(), &w, &h, &channels, 3);
  if (!data) throw Error("cannot read image " + file.string() + ": " + stbi_failure_reason());
  Image image;
  try {
    image = Image(w, h);
  } catch (const Error& e) {
    stbi_image_free(data);
    throw Error("cannot read image " + file.string() + ": " + e.what());
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const stbi_uc* p = data + (static_cast<std::size_t>(y) * w + x) * 3;
      image.set_pixel(x, y, {p[0], p[1], p[2]});
    }
  }
  stbi_image_free(data);
  return image;
}

TopDownTransform::TopDownTransform(const Eigen::Vector2d& world_min, const Eigen::Vector2d& world_max,
                                   double metres_per_pixel, const Margins& margins, const Eigen::Vector2i& origin)
    : world_min_(world_min), world_max_(world_max), metres_per_pixel_(metres_per_pixel), margins_(margins),
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
  if (metres >= 1.0) std::snprintf(text, sizeof(text), "%g m", metres);
  else std::snprintf(text, sizeof(text), "%g cm", metres * 100.0);
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

Eigen::Vector2f draw_colorbar(Image& image, float x, float y, float bar_width, const std::function<Rgb(float)>& colormap,
                              const std::string& lo_label, const std::string& hi_label, const std::string& caption,
                              float text_scale) {
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
    const float top = y + pad + static_cast<float>(i) * row;
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
        image.fill_polygon({c + Eigen::Vector2f(1.2f * h, 0.0f), c + Eigen::Vector2f(-h, h), c + Eigen::Vector2f(-0.4f * h, 0.0f),
                            c + Eigen::Vector2f(-h, -h)},
                           e.color);
        break;
      }
      case LegendEntry::Symbol::kBand:
        image.fill_rect(a.x(), top, b.x(), top + kCapHeight * text_scale, e.color);
        image.stroke_rect(a.x(), top, b.x(), top + kCapHeight * text_scale, colors::kAxis);
        break;
    }
    image.draw_text(x + pad + swatch + pad, top, e.label, {text_scale, colors::kText, HAlign::kLeft, VAlign::kTop, false});
  }
}

}  // namespace tsdf_mcl
