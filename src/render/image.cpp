#include "tsdf_mcl/render/image.hpp"

#include <cairo.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "canvas.hpp"
#include "clip.hpp"
#include "tsdf_mcl/core/checked_math.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/input_file.hpp"

namespace tsdf_mcl {

using Box = Eigen::AlignedBox2d;

namespace {

using detail::ImageAccess;
using render::Canvas;
using render::clamp01;

constexpr double kQuarterTurn = 1.5707963267948966;
// Cairo turns path coordinates into 24.8 fixed point, which ends at 2^23 pixels; paths are clipped well inside.
constexpr double kMaxPathCoordinate = 1 << 21;

Box finite_bounds(const std::vector<Eigen::Vector2f>& points) {
  Box box;
  for (const auto& p : points) {
    if (p.allFinite()) box.extend(p.cast<double>());
  }
  return box;
}

Box grown(const Box& box, double by) {
  return box.isEmpty() ? box : Box(box.min().array() - by, box.max().array() + by);
}

// Round caps and joins; returns the width set: a stroke four canvases wide covers all of the canvas, and wider
// ones would only overflow Cairo's coordinates.
double setup_stroke(const Canvas& canvas, float width) {
  const double w = std::min<double>(width, 4.0 * canvas.guard(0.0).sizes().maxCoeff());
  cairo_set_line_width(canvas.cr(), w);
  cairo_set_line_cap(canvas.cr(), CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(canvas.cr(), CAIRO_LINE_JOIN_ROUND);
  return w;
}

// The polyline's finite runs as subpaths, each segment cut to the guard box. A finite point without finite
// neighbours becomes a subpath of zero length, which round caps draw as a dot.
void add_polyline(cairo_t* cr, const std::vector<Eigen::Vector2f>& points, const Box& guard) {
  bool open = false;  // the current subpath ends at points[i]
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d a = points[i].cast<double>();
    const bool next = i + 1 < points.size() && points[i + 1].allFinite();
    if (!a.allFinite() || !next) {
      if (a.allFinite() && !open && guard.contains(a)) {
        cairo_move_to(cr, a.x(), a.y());
        cairo_line_to(cr, a.x(), a.y());
      }
      open = false;
      continue;
    }
    const Eigen::Vector2d b = points[i + 1].cast<double>();
    Eigen::Vector2d from = a, to = b;
    if (!render::clip_segment(from, to, guard.min(), guard.max())) {
      open = false;
      continue;
    }
    if (!open) cairo_move_to(cr, from.x(), from.y());
    cairo_line_to(cr, to.x(), to.y());
    open = to == b;
  }
}

// Circles whose path would leave Cairo's coordinate range (millions of pixels) are not drawn as paths.
bool drawable_circle(const Eigen::Vector2d& center, double reach) {
  return (center.array().abs() + reach).maxCoeff() < kMaxPathCoordinate;
}

// --- Text ---------------------------------------------------------------------------------------------------------

// Layout in font units, as the old bitmap font had them: capitals kCapHeight (7) units high, lines 12 units apart.
constexpr float kLineAdvance = 12.0f;
// Metrics are measured at this font size (pixels) and scale linearly: metric hinting is off.
constexpr double kReferenceSize = 100.0;

// The text face and its metrics in font units. Where fontconfig finds no font at all, Cairo sets text in a built-in
// one; should even that fail, text keeps its place in layouts (DejaVu Sans' metrics, an estimated width) undrawn.
struct Font {
  cairo_font_face_t* face = nullptr;
  cairo_font_options_t* options = nullptr;
  cairo_scaled_font_t* reference = nullptr;   // the face at kReferenceSize, for measuring
  double size_per_unit = kCapHeight / 0.729;  // font size (em) per font unit: DejaVu's capitals are 0.729 em high
  double ascent = 7.34;                       // ascenders' tops above the baseline
  double descent = 2.27;                      // descenders' bottoms below it
};

const Font& font() {
  static const Font instance = [] {
    Font f;
    f.options = cairo_font_options_create();
    // Grey anti-aliasing (no colour fringes), outlines fitted to the pixel grid vertically, advances unhinted so
    // that a text's size is proportional to its scale and the same in both orientations.
    cairo_font_options_set_antialias(f.options, CAIRO_ANTIALIAS_GRAY);
    cairo_font_options_set_hint_style(f.options, CAIRO_HINT_STYLE_SLIGHT);
    cairo_font_options_set_hint_metrics(f.options, CAIRO_HINT_METRICS_OFF);
    cairo_matrix_t size, identity;
    cairo_matrix_init_scale(&size, kReferenceSize, kReferenceSize);
    cairo_matrix_init_identity(&identity);
    // Fontconfig substitutes its sans-serif default for a missing DejaVu Sans; "sans-serif" itself is the fallback
    // should the first face fail outright.
    for (const char* family : {"DejaVu Sans", "sans-serif"}) {
      cairo_font_face_t* face = cairo_toy_font_face_create(family, CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
      cairo_scaled_font_t* scaled = cairo_scaled_font_create(face, &size, &identity, f.options);
      cairo_text_extents_t cap{}, up{}, down{};
      cairo_scaled_font_text_extents(scaled, "H", &cap);
      cairo_scaled_font_text_extents(scaled, "bdfhkl()|", &up);
      cairo_scaled_font_text_extents(scaled, "gjpqy()|", &down);
      if (cairo_scaled_font_status(scaled) == CAIRO_STATUS_SUCCESS && cap.height > 0.0) {
        f.face = face;
        f.reference = scaled;
        f.size_per_unit = kCapHeight / (cap.height / kReferenceSize);
        const double units_per_pixel = kCapHeight / cap.height;
        f.ascent = std::max<double>(kCapHeight, -up.y_bearing * units_per_pixel);
        f.descent = std::max(0.0, (down.y_bearing + down.height) * units_per_pixel);
        break;
      }
      cairo_scaled_font_destroy(scaled);
      cairo_font_face_destroy(face);
    }
    return f;
  }();
  return instance;
}

// Valid UTF-8 with control characters and malformed bytes replaced by '?' (Cairo refuses invalid UTF-8), split
// into lines.
std::vector<std::string> text_lines(const std::string& text) {
  std::vector<std::string> lines(1);
  for (std::size_t i = 0; i < text.size();) {
    const auto lead = static_cast<unsigned char>(text[i]);
    if (lead == '\n') {
      lines.emplace_back();
      ++i;
      continue;
    }
    const std::size_t n = lead < 0x80                    ? 1
                          : lead >= 0xC2 && lead <= 0xDF ? 2
                          : lead >= 0xE0 && lead <= 0xEF ? 3
                          : lead >= 0xF0 && lead <= 0xF4 ? 4
                                                         : 0;
    std::uint32_t code = n == 1 ? lead : lead & (0x7Fu >> n);
    bool valid = n > 0 && i + n <= text.size();
    for (std::size_t k = 1; valid && k < n; ++k) {
      const auto c = static_cast<unsigned char>(text[i + k]);
      valid = (c & 0xC0) == 0x80;
      code = (code << 6) | (c & 0x3Fu);
    }
    valid = valid && !(n == 3 && code < 0x800) && !(n == 4 && (code < 0x10000 || code > 0x10FFFF)) &&
            !(code >= 0xD800 && code <= 0xDFFF);
    const bool control = code < 0x20 || (code >= 0x7F && code < 0xA0);
    if (valid && !control)
      lines.back().append(text, i, n);
    else
      lines.back() += '?';
    i += valid ? n : 1;
  }
  return lines;
}

// A text laid out in pixels at one scale; v runs down across the lines from the box's top, u along them.
struct TextLayout {
  std::vector<std::string> lines;
  double font_size = 0.0;  // pixels per em
  double pen = 0.0;        // u of each line's start: glyphs reaching left of their origin stay in the box
  double first_baseline = 0.0;
  double line_advance = 0.0;
  Eigen::Vector2f size = Eigen::Vector2f::Zero();
};

TextLayout layout_text(const std::string& text, float scale) {
  TextLayout t;
  if (text.empty() || !(scale > 0.0f)) return t;
  const Font& f = font();
  t.lines = text_lines(text);
  t.font_size = scale * f.size_per_unit;
  t.first_baseline = scale * f.ascent;
  t.line_advance = scale * kLineAdvance;
  double overhang = 0.0, right = 0.0;  // at the reference size
  for (const std::string& line : t.lines) {
    cairo_text_extents_t e{};
    if (f.reference)
      cairo_scaled_font_text_extents(f.reference, line.c_str(), &e);
    else
      e.x_advance = 0.55 * kReferenceSize * static_cast<double>(line.size());
    overhang = std::max(overhang, -e.x_bearing);
    right = std::max({right, e.x_advance, e.x_bearing + e.width});
  }
  const double pixels_per_reference = t.font_size / kReferenceSize;
  t.pen = overhang * pixels_per_reference;
  const double height = f.ascent + static_cast<double>(t.lines.size() - 1) * kLineAdvance + f.descent;
  t.size = Eigen::Vector2d((overhang + right) * pixels_per_reference, scale * height).cast<float>();
  return t;
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
  static constexpr std::array<Rgb, 10> kTab10 = {
      rgb_hex(0x1f77b4), rgb_hex(0xff7f0e), rgb_hex(0x2ca02c), rgb_hex(0xd62728), rgb_hex(0x9467bd),
      rgb_hex(0x8c564b), rgb_hex(0xe377c2), rgb_hex(0x7f7f7f), rgb_hex(0xbcbd22), rgb_hex(0x17becf)};
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
  xrgb_.resize(static_cast<std::size_t>(width) * height);
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
  const std::size_t i = static_cast<std::size_t>(y) * width_ + x;
  pixels_[3 * i] = color.r;
  pixels_[3 * i + 1] = color.g;
  pixels_[3 * i + 2] = color.b;
  xrgb_[i] = std::uint32_t{color.r} << 16 | std::uint32_t{color.g} << 8 | color.b;
}

void Image::blend_pixel(int x, int y, Rgb color, float alpha) {
  if (x < clip_x0_ || x >= clip_x1_ || y < clip_y0_ || y >= clip_y1_ || !(alpha > 0.0f)) return;
  set_pixel(x, y, mix(at(x, y), color, alpha));
}

void Image::fill(Rgb color) {
  for (int y = clip_y0_; y < clip_y1_; ++y) {
    for (int x = clip_x0_; x < clip_x1_; ++x) set_pixel(x, y, color);
  }
}

void Image::fill_rect(float x0, float y0, float x1, float y1, Rgb color, float alpha) {
  if (std::isnan(x0) || std::isnan(y0) || std::isnan(x1) || std::isnan(y1)) return;
  const Box box(Eigen::Vector2d(std::min(x0, x1), std::min(y0, y1)),
                Eigen::Vector2d(std::max(x0, x1), std::max(y0, y1)));
  const Canvas canvas(*this, box);
  if (!canvas) return;
  // Clamping an axis-aligned rectangle to the guard box changes nothing that shows.
  const Box r = box.intersection(canvas.guard(1.0));
  canvas.set_color(color, alpha);
  cairo_rectangle(canvas.cr(), r.min().x(), r.min().y(), r.sizes().x(), r.sizes().y());
  cairo_fill(canvas.cr());
}

void Image::stroke_rect(float x0, float y0, float x1, float y1, Rgb color, float width) {
  if (x1 < x0) std::swap(x0, x1);
  if (y1 < y0) std::swap(y0, y1);
  width = std::min({width, (x1 - x0) / 2.0f, (y1 - y0) / 2.0f});
  if (!(width > 0.0f)) return;
  const Box outer(Eigen::Vector2d(x0, y0), Eigen::Vector2d(x1, y1));
  const Canvas canvas(*this, outer);
  if (!canvas) return;
  // The ring between the rectangle and the one inset by the width: even-odd fill of both.
  const Box guard = canvas.guard(2.0);
  const Box a = outer.intersection(guard);
  const Box b = Box(outer.min().array() + width, outer.max().array() - width).intersection(guard);
  canvas.set_color(color, 1.0f);
  cairo_set_fill_rule(canvas.cr(), CAIRO_FILL_RULE_EVEN_ODD);
  cairo_rectangle(canvas.cr(), a.min().x(), a.min().y(), a.sizes().x(), a.sizes().y());
  if (!b.isEmpty()) cairo_rectangle(canvas.cr(), b.min().x(), b.min().y(), b.sizes().x(), b.sizes().y());
  cairo_fill(canvas.cr());
}

void Image::draw_line(const Eigen::Vector2f& a, const Eigen::Vector2f& b, Rgb color, float width, float alpha) {
  draw_polyline({a, b}, color, width, alpha);
}

void Image::draw_polyline(const std::vector<Eigen::Vector2f>& points, Rgb color, float width, float alpha) {
  if (!(width > 0.0f)) return;
  const Canvas canvas(*this, grown(finite_bounds(points), width / 2.0 + 1.0));
  if (!canvas) return;
  // One stroke for the whole polyline: Cairo covers its overlapping parts (joints) once.
  canvas.set_color(color, alpha);
  const Box guard = canvas.guard(setup_stroke(canvas, width) + 2.0);
  add_polyline(canvas.cr(), points, guard);
  cairo_stroke(canvas.cr());
}

void Image::draw_dashed_line(const Eigen::Vector2f& a, const Eigen::Vector2f& b, Rgb color, float width,
                             float dash_length, float alpha) {
  draw_dashed_polyline({a, b}, color, width, dash_length, alpha);
}

void Image::draw_dashed_polyline(const std::vector<Eigen::Vector2f>& points, Rgb color, float width, float dash_length,
                                 float alpha) {
  // Dashes shorter than half a pixel would look like a solid line anyway.
  if (!(dash_length >= 0.5f)) {
    draw_polyline(points, color, width, alpha);
    return;
  }
  if (!(width > 0.0f)) return;
  const Canvas canvas(*this, grown(finite_bounds(points), width / 2.0 + 1.0));
  if (!canvas) return;
  canvas.set_color(color, alpha);
  const Box guard = canvas.guard(setup_stroke(canvas, width) + 2.0);
  // Round caps add `cap` at both ends of a dash; dashes shortened by them keep dash and gap visibly equal. The
  // pattern starts in the gap, `cap` before the first dash.
  const double cap = std::min(width / 2.0, dash_length / 4.0);
  const double pattern[2] = {dash_length - 2.0 * cap, dash_length + 2.0 * cap};
  cairo_set_dash(canvas.cr(), pattern, 2, 2.0 * dash_length - cap);
  add_polyline(canvas.cr(), points, guard);
  cairo_stroke(canvas.cr());
}

void Image::fill_circle(const Eigen::Vector2f& center, float radius, Rgb color, float alpha) {
  if (!center.allFinite() || !(radius > 0.0f)) return;
  const Eigen::Vector2d c = center.cast<double>();
  const Canvas canvas(*this, grown(Box(c, c), radius + 1.0));
  if (!canvas) return;
  canvas.set_color(color, alpha);
  if (!drawable_circle(c, radius)) {
    const Box g = canvas.guard(0.0);  // drawn only where it covers all of the canvas
    if ((g.min() - c).cwiseAbs().cwiseMax((g.max() - c).cwiseAbs()).norm() >= radius) return;
    cairo_rectangle(canvas.cr(), g.min().x(), g.min().y(), g.sizes().x(), g.sizes().y());
  } else {
    cairo_arc(canvas.cr(), c.x(), c.y(), radius, 0.0, 4.0 * kQuarterTurn);
  }
  cairo_fill(canvas.cr());
}

void Image::stroke_circle(const Eigen::Vector2f& center, float radius, Rgb color, float width, float alpha) {
  if (!center.allFinite() || !(radius > 0.0f) || !(width > 0.0f)) return;
  const Eigen::Vector2d c = center.cast<double>();
  const Canvas canvas(*this, grown(Box(c, c), radius + width / 2.0 + 1.0));
  if (!canvas) return;
  if (!drawable_circle(c, radius + width / 2.0)) return;
  canvas.set_color(color, alpha);
  setup_stroke(canvas, width);
  cairo_arc(canvas.cr(), c.x(), c.y(), radius, 0.0, 4.0 * kQuarterTurn);
  cairo_stroke(canvas.cr());
}

void Image::fill_polygon(const std::vector<Eigen::Vector2f>& points, Rgb color, float alpha) {
  std::vector<Eigen::Vector2d> polygon;
  for (const auto& p : points) {
    if (p.allFinite()) polygon.push_back(p.cast<double>());
  }
  if (polygon.size() < 3) return;
  const Canvas canvas(*this, grown(finite_bounds(points), 1.0));
  if (!canvas) return;
  const Box guard = canvas.guard(2.0);
  polygon = render::clip_polygon(std::move(polygon), guard.min(), guard.max());
  if (polygon.empty()) return;
  canvas.set_color(color, alpha);
  cairo_set_fill_rule(canvas.cr(), CAIRO_FILL_RULE_EVEN_ODD);
  cairo_move_to(canvas.cr(), polygon.front().x(), polygon.front().y());
  for (const auto& p : polygon) cairo_line_to(canvas.cr(), p.x(), p.y());
  cairo_close_path(canvas.cr());
  cairo_fill(canvas.cr());
}

Eigen::Vector2f text_size(const std::string& text, float scale) { return layout_text(text, scale).size; }

Eigen::Vector4f Image::draw_text(float x, float y, const std::string& text, const TextStyle& style) {
  const TextLayout t = layout_text(text, style.scale);
  // The anchor aligns the block of capitals; descenders hang below a bottom- or middle-aligned line as in print.
  const double last_baseline = t.first_baseline + static_cast<double>(t.lines.size()) * t.line_advance - t.line_advance;
  const double caps_top = t.first_baseline - kCapHeight * style.scale;
  double along = 0.0;   // offset of the box's start along its reading direction
  double across = 0.0;  // offset of its top across it
  if (style.h_align == HAlign::kCenter) along = -t.size.x() / 2.0;
  if (style.h_align == HAlign::kRight) along = -t.size.x();
  if (style.v_align == VAlign::kMiddle) across = -(caps_top + last_baseline) / 2.0;
  if (style.v_align == VAlign::kBottom) across = -last_baseline;
  // Point (u, v) of the box (u along the text, v down across it) in image pixels.
  auto place = [&](double u, double v) -> Eigen::Vector2d {
    if (style.vertical) return {x + across + v, y - along - u};
    return {x + along + u, y + across + v};
  };
  Box box;
  box.extend(place(0.0, 0.0)).extend(place(t.size.x(), t.size.y()));
  const Eigen::Vector4f result(static_cast<float>(box.min().x()), static_cast<float>(box.min().y()),
                               static_cast<float>(box.max().x()), static_cast<float>(box.max().y()));
  const Font& f = font();
  if (t.lines.empty() || !f.face || !box.min().allFinite() || !box.max().allFinite()) return result;
  // Accents and glyphs reaching past their advance may leave the box a little.
  const Canvas canvas(*this, grown(box, 0.3 * t.font_size + 1.0));
  if (!canvas) return result;
  if ((box.min().array().abs() > kMaxPathCoordinate).any() || (box.max().array().abs() > kMaxPathCoordinate).any()) {
    return result;
  }
  cairo_t* cr = canvas.cr();
  canvas.set_color(style.color, 1.0f);
  cairo_set_font_face(cr, f.face);
  cairo_set_font_size(cr, t.font_size);
  cairo_set_font_options(cr, f.options);
  cairo_translate(cr, x, y);
  if (style.vertical) cairo_rotate(cr, -kQuarterTurn);
  for (std::size_t k = 0; k < t.lines.size(); ++k) {
    cairo_move_to(cr, along + t.pen, across + t.first_baseline + static_cast<double>(k) * t.line_advance);
    // Cairo rasterizes each glyph once into a cache; glyphs hundreds of pixels high are better filled as paths.
    if (t.font_size <= 512.0) {
      cairo_show_text(cr, t.lines[k].c_str());
    } else {
      cairo_text_path(cr, t.lines[k].c_str());
      cairo_fill(cr);
    }
  }
  return result;
}

void Image::blit(const Image& source, int x, int y) {
  const int x0 = std::max(clip_x0_, x), x1 = std::min(clip_x1_, x + source.width());
  if (x1 <= x0) return;
  for (int sy = std::max(0, clip_y0_ - y); sy < std::min(source.height(), clip_y1_ - y); ++sy) {
    const std::size_t from = static_cast<std::size_t>(sy) * source.width() + (x0 - x);
    const std::size_t to = static_cast<std::size_t>(y + sy) * width_ + x0;
    std::copy_n(source.xrgb_.begin() + from, x1 - x0, xrgb_.begin() + to);
    std::copy_n(source.pixels_.begin() + 3 * from, 3 * (x1 - x0), pixels_.begin() + 3 * to);
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

}  // namespace tsdf_mcl
