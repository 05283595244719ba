#pragma once
// RGB8 images and the drawing primitives that the plots and map views are made of, drawn with Cairo.
//
// Coordinates are continuous pixels: pixel (i, j) is the unit square [i, i+1) x [j, j+1), x to the right, y
// downwards. Integer coordinates therefore fall on pixel edges (rectangles are crisp there) and a 1-pixel line
// is crisp at half-integers. Edges are anti-aliased by coverage; every primitive is clipped to the image (and
// to the clip rectangle), so drawing partly or wholly outside is harmless, and so are non-finite or huge
// coordinates (the parts of a shape beyond them are left out).
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace tsdf_mcl {

struct Rgb {
  std::uint8_t r = 0;
  std::uint8_t g = 0;
  std::uint8_t b = 0;

  friend constexpr bool operator==(Rgb lhs, Rgb rhs) { return lhs.r == rhs.r && lhs.g == rhs.g && lhs.b == rhs.b; }
  friend constexpr bool operator!=(Rgb lhs, Rgb rhs) { return !(lhs == rhs); }
};

constexpr Rgb rgb_hex(std::uint32_t hex) {
  return {static_cast<std::uint8_t>(hex >> 16), static_cast<std::uint8_t>(hex >> 8), static_cast<std::uint8_t>(hex)};
}

namespace colors {
inline constexpr Rgb kWhite{255, 255, 255};
inline constexpr Rgb kBlack{0, 0, 0};
inline constexpr Rgb kText = rgb_hex(0x222222);
inline constexpr Rgb kGrid = rgb_hex(0xe3e3e3);
inline constexpr Rgb kAxis = rgb_hex(0x555555);
}  // namespace colors

// a + t (b - a), t clamped to [0, 1].
Rgb mix(Rgb a, Rgb b, float t);
// Viridis (perceptually uniform, readable in greyscale and by colour-blind readers); t clamped to [0, 1].
Rgb viridis(float t);
// The i-th colour of a categorical palette (matplotlib's tab10), repeating after ten.
Rgb palette_color(std::size_t i);

enum class HAlign { kLeft, kCenter, kRight };
enum class VAlign { kTop, kMiddle, kBottom };

// The largest width and height of an image, in pixels (Cairo's limit).
inline constexpr int kMaxImageSide = 32767;

// Text is set in DejaVu Sans (or, where that font is missing, fontconfig's sans-serif), sized in font units: capitals
// are 7 units high, lines 12 units apart.
struct TextStyle {
  float scale = 2.0f;  // pixels per font unit: 2 gives 14-pixel capitals
  Rgb color = colors::kText;
  HAlign h_align = HAlign::kLeft;
  VAlign v_align = VAlign::kTop;
  bool vertical = false;  // rotated a quarter turn counter-clockwise, reading upwards (y-axis labels)
};

namespace detail {
struct ImageAccess;
}

class Image {
 public:
  Image() = default;
  // Throws Error unless 1 <= width, height <= kMaxImageSide.
  Image(int width, int height, Rgb background = colors::kWhite);

  int width() const { return width_; }
  int height() const { return height_; }
  bool empty() const { return pixels_.empty(); }
  // Rows top to bottom, 3 bytes (r, g, b) per pixel.
  const std::vector<std::uint8_t>& pixels() const { return pixels_; }
  // Throws Error outside the image.
  Rgb at(int x, int y) const;

  // Drawing is limited to pixels x0 <= x < x1, y0 <= y < y1 (intersected with the image) until reset_clip().
  void set_clip(int x0, int y0, int x1, int y1);
  void reset_clip();

  void set_pixel(int x, int y, Rgb color);
  // Composites color over the pixel with the given opacity (0..1).
  void blend_pixel(int x, int y, Rgb color, float alpha);
  void fill(Rgb color);

  void fill_rect(float x0, float y0, float x1, float y1, Rgb color, float alpha = 1.0f);
  // Outline whose stroke lies inside the rectangle.
  void stroke_rect(float x0, float y0, float x1, float y1, Rgb color, float width = 1.0f);
  // Round caps; a polyline is blended once, so its joints do not show darker under alpha < 1.
  void draw_line(const Eigen::Vector2f& a, const Eigen::Vector2f& b, Rgb color, float width = 1.0f, float alpha = 1.0f);
  void draw_polyline(const std::vector<Eigen::Vector2f>& points, Rgb color, float width = 1.0f, float alpha = 1.0f);
  // Dashes of dash_length pixels separated by gaps of the same length, starting with a dash at the first point;
  // the pattern runs on around corners (it starts again after a gap of non-finite points).
  void draw_dashed_line(const Eigen::Vector2f& a, const Eigen::Vector2f& b, Rgb color, float width = 1.0f,
                        float dash_length = 6.0f, float alpha = 1.0f);
  void draw_dashed_polyline(const std::vector<Eigen::Vector2f>& points, Rgb color, float width = 1.0f,
                            float dash_length = 6.0f, float alpha = 1.0f);
  void fill_circle(const Eigen::Vector2f& center, float radius, Rgb color, float alpha = 1.0f);
  void stroke_circle(const Eigen::Vector2f& center, float radius, Rgb color, float width = 1.0f, float alpha = 1.0f);
  // Any simple polygon (even-odd rule).
  void fill_polygon(const std::vector<Eigen::Vector2f>& points, Rgb color, float alpha = 1.0f);

  // Text (UTF-8; control characters and malformed bytes are drawn as '?', '\n' starts a line) anchored at (x, y)
  // per the style's alignment: kTop puts the box's top at y, kMiddle centres the capitals on y, kBottom puts the
  // last line's baseline on y (descenders hang below it). Returns the box it covers as (x0, y0, x1, y1); only
  // accents above capitals may reach above it.
  Eigen::Vector4f draw_text(float x, float y, const std::string& text, const TextStyle& style = {});

  // Copies source with its top-left corner at (x, y), clipped.
  void blit(const Image& source, int x, int y);

 private:
  friend struct detail::ImageAccess;  // hands the pixels to Cairo (image.cpp)

  int width_ = 0;
  int height_ = 0;
  std::vector<std::uint8_t> pixels_;
  // The same pixels as Cairo draws on (CAIRO_FORMAT_RGB24: 0x00RRGGBB per pixel); every change reaches both.
  std::vector<std::uint32_t> xrgb_;
  int clip_x0_ = 0, clip_y0_ = 0, clip_x1_ = 0, clip_y1_ = 0;
};

// Size in pixels (width, height) of a text's box as draw_text lays it out (unrotated): its width is the advance of
// its longest line, its height reaches from the tops of ascenders (d, l, k: a little above the capitals, which are
// 7 * scale high) to the bottoms of descenders (one line: about 9.6 * scale); lines are 12 * scale apart.
Eigen::Vector2f text_size(const std::string& text, float scale = 2.0f);
// Capitals are this many font units high (pixels at scale 1): what widgets align text boxes by.
inline constexpr float kCapHeight = 7.0f;

// Images laid out left to right in rows of `columns`, separated by gap pixels; cells are as large as the largest
// image. Throws Error for an empty list.
Image compose_grid(const std::vector<Image>& images, int columns, int gap = 0, Rgb background = colors::kWhite);

// Encodes as PNG; throws Error naming the file if it cannot be written (missing folder, permissions, disk full).
void save_png(const Image& image, const std::filesystem::path& file);
// Reads a PNG as RGB (transparent pixels composited over white); throws Error naming the file on failure.
Image load_png(const std::filesystem::path& file);

// Margins around the drawing area of a view, in pixels.
struct Margins {
  int left = 0;
  int top = 0;
  int right = 0;
  int bottom = 0;
};

// Top-down view: world x to the right, world y up, a fixed number of metres per pixel, the world box
// [world_min, world_max] filling the area inside the margins; origin shifts the whole view inside a larger
// image (panels).
class TopDownTransform {
 public:
  TopDownTransform() = default;
  // Throws Error for a non-positive or non-finite scale or an empty box.
  TopDownTransform(const Eigen::Vector2d& world_min, const Eigen::Vector2d& world_max, double metres_per_pixel,
                   const Margins& margins = {}, const Eigen::Vector2i& origin = Eigen::Vector2i::Zero());

  Eigen::Vector2f to_pixel(const Eigen::Vector2d& world) const;
  Eigen::Vector2d to_world(const Eigen::Vector2f& pixel) const;
  double metres_per_pixel() const { return metres_per_pixel_; }
  const Eigen::Vector2d& world_min() const { return world_min_; }
  const Eigen::Vector2d& world_max() const { return world_max_; }
  // Size of the whole view including margins, and the drawing area (x0, y0, x1, y1) in image pixels.
  int width() const { return margins_.left + area_width_ + margins_.right; }
  int height() const { return margins_.top + area_height_ + margins_.bottom; }
  Eigen::Vector4i area() const;
  TopDownTransform moved_to(const Eigen::Vector2i& origin) const;

 private:
  Eigen::Vector2d world_min_ = Eigen::Vector2d::Zero();
  Eigen::Vector2d world_max_ = Eigen::Vector2d::Zero();
  double metres_per_pixel_ = 1.0;
  Margins margins_;
  Eigen::Vector2i origin_ = Eigen::Vector2i::Zero();
  int area_width_ = 0;
  int area_height_ = 0;
};

// The largest 1-2-5 x 10^k value not above `limit` (> 0): lengths of scale bars, steps of axis ticks.
double nice_number_at_most(double limit);

// A labelled scale bar ("2 m") of a nice length no longer than max_length_px, its left end at (x, y) (the bar's
// baseline), on a translucent white plate so that it stays readable over a map.
void draw_scale_bar(Image& image, const TopDownTransform& view, float x, float y, float max_length_px,
                    float text_scale = 2.0f);

// A horizontal colour bar: caption, the bar (colormap from 0 at the left to 1 at the right) and the labels of its
// ends below it, top-left at (x, y). Returns its size (width, height).
Eigen::Vector2f draw_colorbar(Image& image, float x, float y, float bar_width,
                              const std::function<Rgb(float)>& colormap, const std::string& lo_label,
                              const std::string& hi_label, const std::string& caption, float text_scale = 2.0f);

// One row of a legend.
struct LegendEntry {
  enum class Symbol { kLine, kDashedLine, kDot, kRing, kBand, kArrow };
  std::string label;
  Rgb color;
  Symbol symbol = Symbol::kLine;
};
// Size (width, height) of the legend box for these entries.
Eigen::Vector2f legend_size(const std::vector<LegendEntry>& entries, float text_scale = 2.0f);
// A boxed legend, one entry per row, top-left at (x, y).
void draw_legend(Image& image, float x, float y, const std::vector<LegendEntry>& entries, float text_scale = 2.0f);

}  // namespace tsdf_mcl
