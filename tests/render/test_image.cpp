#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "map_test_helpers.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/render/image.hpp"

using Eigen::Vector2d;
using Eigen::Vector2f;
using tsdf_mcl::Error;
using tsdf_mcl::Image;
using tsdf_mcl::Rgb;
using tsdf_mcl::rgb_hex;
using tsdf_mcl::test::TempDir;
namespace colors = tsdf_mcl::colors;

namespace {

constexpr Rgb kRed{200, 0, 0};

bool dark(Rgb c) { return c.r < 128 && c.g < 128 && c.b < 128; }

// Bounding box of the pixels darker than `threshold` in red (or, by default, of all differing from the background).
struct Ink {
  int pixels = 0;
  float x0 = 1e9f, y0 = 1e9f, x1 = -1e9f, y1 = -1e9f;  // pixel edges
};
Ink ink_of(const Image& image, Rgb background, int threshold = 256) {
  Ink ink;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const Rgb c = image.at(x, y);
      if (c == background || c.r >= threshold) continue;
      ++ink.pixels;
      ink.x0 = std::min(ink.x0, static_cast<float>(x));
      ink.y0 = std::min(ink.y0, static_cast<float>(y));
      ink.x1 = std::max(ink.x1, static_cast<float>(x + 1));
      ink.y1 = std::max(ink.y1, static_cast<float>(y + 1));
    }
  }
  return ink;
}

int count_not(const Image& image, Rgb background) {
  int n = 0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) n += image.at(x, y) != background;
  }
  return n;
}

}  // namespace

TEST(ImageCanvas, StartsFilledAndChecksItsSize) {
  const Image image(7, 5, kRed);
  EXPECT_EQ(image.width(), 7);
  EXPECT_EQ(image.height(), 5);
  EXPECT_EQ(image.pixels().size(), 7u * 5u * 3u);
  EXPECT_EQ(image.at(6, 4), kRed);
  EXPECT_THROW(image.at(7, 0), Error);
  EXPECT_THROW(image.at(0, -1), Error);
  EXPECT_THROW(Image(0, 5), Error);
  EXPECT_THROW(Image(5, 40000), Error);
  EXPECT_THROW(Image(tsdf_mcl::kMaxImageSide + 1, 1), Error);
}

TEST(ImageCanvas, LineCoversItsEndpointsAndThePathBetween) {
  Image image(100, 60);
  image.draw_line({10.5f, 10.5f}, {80.5f, 40.5f}, colors::kBlack, 1.5f);
  EXPECT_TRUE(dark(image.at(10, 10)));
  EXPECT_TRUE(dark(image.at(80, 40)));
  EXPECT_TRUE(dark(image.at(45, 25)));
  for (int x = 11; x < 80; ++x) {
    // The line passes through y = 10.5 + (x - 10) * 30 / 70 at the pixel's centre column.
    const int y = static_cast<int>(std::floor(10.5 + (x + 0.5 - 10.5) * 30.0 / 70.0));
    EXPECT_LT(image.at(x, y).r, 160) << x;
  }
  EXPECT_EQ(image.at(10, 50), colors::kWhite);
  EXPECT_EQ(image.at(90, 5), colors::kWhite);
}

TEST(ImageCanvas, LineWidthIsHonoured) {
  Image image(100, 60);
  image.draw_line({10.0f, 30.5f}, {90.0f, 30.5f}, colors::kBlack, 5.0f);
  for (int y = 28; y <= 32; ++y) EXPECT_EQ(image.at(50, y), colors::kBlack) << y;
  EXPECT_EQ(image.at(50, 26), colors::kWhite);
  EXPECT_EQ(image.at(50, 34), colors::kWhite);
}

TEST(ImageCanvas, RectanglesOnIntegerCoordinatesAreCrispAndAlphaBlends) {
  Image image(40, 40);
  image.fill_rect(10.0f, 10.0f, 20.0f, 20.0f, kRed);
  EXPECT_EQ(image.at(10, 10), kRed);
  EXPECT_EQ(image.at(19, 19), kRed);
  EXPECT_EQ(image.at(20, 20), colors::kWhite);
  EXPECT_EQ(image.at(9, 15), colors::kWhite);
  EXPECT_EQ(count_not(image, colors::kWhite), 100);

  image.fill_rect(0.0f, 30.0f, 10.0f, 40.0f, colors::kBlack, 0.5f);
  EXPECT_NEAR(image.at(5, 35).r, 128, 1);
  // Half-covered edge pixels get half the opacity.
  image.fill_rect(30.5f, 30.0f, 35.0f, 31.0f, colors::kBlack);
  EXPECT_NEAR(image.at(30, 30).r, 128, 1);
  EXPECT_EQ(image.at(31, 30), colors::kBlack);
}

TEST(ImageCanvas, CircleHasItsArea) {
  Image image(60, 60);
  image.fill_circle({30.0f, 30.0f}, 10.0f, colors::kBlack);
  EXPECT_EQ(image.at(30, 30), colors::kBlack);
  EXPECT_EQ(image.at(30, 42), colors::kWhite);
  float ink = 0.0f;
  for (int y = 0; y < 60; ++y) {
    for (int x = 0; x < 60; ++x) ink += 1.0f - static_cast<float>(image.at(x, y).r) / 255.0f;
  }
  EXPECT_NEAR(ink, 3.14159f * 100.0f, 3.0f);
}

TEST(ImageCanvas, PolylineJointsAreNotDarkerUnderAlpha) {
  Image image(100, 100);
  image.draw_polyline({{10.5f, 50.5f}, {50.5f, 50.5f}, {50.5f, 90.5f}}, colors::kBlack, 3.0f, 0.5f);
  EXPECT_EQ(image.at(50, 50), image.at(30, 50));
  EXPECT_NEAR(image.at(30, 50).r, 128, 1);
}

TEST(ImageCanvas, DashedLineHasDashesAndGaps) {
  Image image(100, 20);
  image.draw_dashed_line({0.0f, 10.5f}, {100.0f, 10.5f}, colors::kBlack, 1.0f, 10.0f);
  int ink = 0, gaps = 0;
  for (int x = 0; x < 100; ++x) (image.at(x, 10).r < 128 ? ink : gaps)++;
  EXPECT_GT(ink, 30);
  EXPECT_GT(gaps, 30);
  EXPECT_TRUE(dark(image.at(5, 10)));
  EXPECT_EQ(image.at(15, 10), colors::kWhite);
}

TEST(ImageCanvas, PolygonFillsItsInside) {
  Image image(50, 50);
  image.fill_polygon({{10.0f, 10.0f}, {40.0f, 10.0f}, {10.0f, 40.0f}}, kRed);
  EXPECT_EQ(image.at(15, 15), kRed);
  EXPECT_EQ(image.at(35, 35), colors::kWhite);
  EXPECT_NEAR(count_not(image, colors::kWhite), 450, 35);
}

TEST(ImageCanvas, TextDrawsInkInsideItsBox) {
  Image image(220, 60);
  const std::string text = "Height 1.5 mg";
  const Eigen::Vector4f box = image.draw_text(10.0f, 10.0f, text, {2.0f, colors::kBlack});
  const Vector2f size = tsdf_mcl::text_size(text, 2.0f);
  EXPECT_FLOAT_EQ(box.x(), 10.0f);
  EXPECT_FLOAT_EQ(box.y(), 10.0f);
  EXPECT_FLOAT_EQ(box.z() - box.x(), size.x());
  EXPECT_FLOAT_EQ(box.w() - box.y(), size.y());
  EXPECT_NEAR(size.y(), 2.0f * 9.6f, 1.0f);  // ascenders to descenders of one line
  const Ink ink = ink_of(image, colors::kWhite);
  EXPECT_GT(ink.pixels, 100);
  // All ink inside the box (anti-aliasing may touch the pixels along its edges), and the box no larger than the ink:
  // the ascender of 'H'/'1' near its top, the descender of 'g' near its bottom.
  EXPECT_GE(ink.x0, box.x() - 1.0f);
  EXPECT_LE(ink.x1, box.z() + 1.0f);
  EXPECT_GE(ink.y0, box.y() - 1.0f);
  EXPECT_LE(ink.y1, box.w() + 1.0f);
  EXPECT_LT(ink.x0, box.x() + 4.0f);
  EXPECT_GT(ink.x1, box.z() - 4.0f);
  EXPECT_LT(ink.y0, box.y() + 2.0f);
  EXPECT_GT(ink.y1, box.w() - 2.0f);
  // Lines are 12 units apart; the box grows by that per line.
  EXPECT_NEAR(tsdf_mcl::text_size("a\nb\nc", 2.0f).y() - tsdf_mcl::text_size("a", 2.0f).y(), 48.0f, 1e-3f);
  EXPECT_EQ(tsdf_mcl::text_size("", 2.0f), Vector2f::Zero());
}

TEST(ImageCanvas, TextIsSetInARealFont) {
  // Capitals are 7 units high: 14 pixels at scale 2, 28 at scale 4.
  for (const float scale : {2.0f, 4.0f}) {
    Image image(200, 80);
    image.draw_text(10.0f, 10.0f, "HEH", {scale, colors::kBlack});
    const Ink ink = ink_of(image, colors::kWhite, 128);
    EXPECT_NEAR(ink.y1 - ink.y0, 7.0f * scale, 1.0f) << scale;
  }
  // A proportional font: an 'i' is much narrower than an 'M'; sizes scale with the text scale.
  EXPECT_LT(tsdf_mcl::text_size("iiii", 2.0f).x(), 0.5f * tsdf_mcl::text_size("MMMM", 2.0f).x());
  EXPECT_NEAR(tsdf_mcl::text_size("Height", 4.0f).x(), 2.0f * tsdf_mcl::text_size("Height", 2.0f).x(), 1e-3f);
  // Anti-aliased: edges have shades between ink and paper.
  Image a(120, 40), b(120, 40);
  a.draw_text(5.0f, 5.0f, "Ocean 08", {2.0f, colors::kBlack});
  b.draw_text(5.0f, 5.0f, "Sound 36", {2.0f, colors::kBlack});
  int grey = 0;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) grey += a.at(x, y).r > 40 && a.at(x, y).r < 215;
  }
  EXPECT_GT(grey, 20);
  // Different strings give different ink; the same string gives the same.
  EXPECT_NE(a.pixels(), b.pixels());
  Image again(120, 40);
  again.draw_text(5.0f, 5.0f, "Ocean 08", {2.0f, colors::kBlack});
  EXPECT_EQ(again.pixels(), a.pixels());
  // UTF-8 beyond ASCII is drawn in its own glyphs, not as '?'.
  Image umlaut(60, 40), question(60, 40);
  umlaut.draw_text(5.0f, 5.0f, "\xc3\xa4 \xc2\xb0", {2.0f, colors::kBlack});  // "a-umlaut degree"
  question.draw_text(5.0f, 5.0f, "? ?", {2.0f, colors::kBlack});
  EXPECT_GT(count_not(umlaut, colors::kWhite), 20);
  EXPECT_NE(umlaut.pixels(), question.pixels());
}

TEST(ImageCanvas, TextAlignsAndRotates) {
  Image image(200, 200);
  const Eigen::Vector4f centred = image.draw_text(
      100.0f, 50.0f, "HEH", {2.0f, colors::kBlack, tsdf_mcl::HAlign::kCenter, tsdf_mcl::VAlign::kMiddle});
  EXPECT_NEAR((centred.x() + centred.z()) / 2.0f, 100.0f, 0.01f);
  const Ink caps = ink_of(image, colors::kWhite, 128);
  EXPECT_NEAR((caps.y0 + caps.y1) / 2.0f, 50.0f, 1.0f);  // capitals centred on y
  EXPECT_NEAR((caps.x0 + caps.x1) / 2.0f, 100.0f, 1.5f);

  Image bottom(200, 60);
  const Eigen::Vector4f right = bottom.draw_text(
      150.0f, 40.0f, "HEH", {2.0f, colors::kBlack, tsdf_mcl::HAlign::kRight, tsdf_mcl::VAlign::kBottom});
  EXPECT_FLOAT_EQ(right.z(), 150.0f);
  EXPECT_NEAR(ink_of(bottom, colors::kWhite, 128).y1, 40.0f, 1.0f);  // the baseline on y
  EXPECT_GT(right.w(), 40.0f + 3.0f);                                // room for descenders below it

  const Eigen::Vector4f up = image.draw_text(
      20.0f, 150.0f, "vertical", {2.0f, colors::kBlack, tsdf_mcl::HAlign::kLeft, tsdf_mcl::VAlign::kTop, true});
  EXPECT_NEAR(up.w() - up.y(), tsdf_mcl::text_size("vertical", 2.0f).x(), 1e-3f);
  EXPECT_NEAR(up.z() - up.x(), tsdf_mcl::text_size("vertical", 2.0f).y(), 1e-3f);
  EXPECT_NEAR(up.w(), 150.0f, 0.01f);  // reads upwards from the anchor
  EXPECT_NEAR(up.x(), 20.0f, 0.01f);   // the tops of the letters face left, towards x
  int ink = 0, ink_outside = 0;
  for (int y = 90; y < 200; ++y) {
    for (int x = 0; x < 60; ++x) {
      const bool in = x >= up.x() - 1 && x <= up.z() + 1 && y >= up.y() - 1 && y <= up.w() + 1;
      (in ? ink : ink_outside) += image.at(x, y) != colors::kWhite;
    }
  }
  EXPECT_GT(ink, 50);
  EXPECT_EQ(ink_outside, 0);
  // Control characters and malformed UTF-8 are drawn as '?' instead of being handed to Cairo.
  Image other(100, 30), questions(100, 30);
  other.draw_text(5.0f, 5.0f, std::string("\x01\xff\xe4\n"), {2.0f, colors::kBlack});
  questions.draw_text(5.0f, 5.0f, "???", {2.0f, colors::kBlack});
  EXPECT_GT(count_not(other, colors::kWhite), 0);
  EXPECT_EQ(other.pixels(), questions.pixels());
}

TEST(ImageCanvas, ClippingAndWildCoordinatesAreHarmless) {
  Image image(50, 50);
  image.set_clip(10, 10, 20, 20);
  image.fill(kRed);
  EXPECT_EQ(image.at(10, 10), kRed);
  EXPECT_EQ(image.at(19, 19), kRed);
  EXPECT_EQ(image.at(9, 10), colors::kWhite);
  EXPECT_EQ(image.at(20, 19), colors::kWhite);
  image.draw_line({-1000.0f, 15.0f}, {1000.0f, 15.0f}, colors::kBlack, 3.0f);
  EXPECT_EQ(image.at(30, 15), colors::kWhite);
  EXPECT_TRUE(dark(image.at(15, 15)));
  image.reset_clip();

  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  Image other(30, 30);
  other.draw_line({-50.0f, -50.0f}, {100.0f, 100.0f}, colors::kBlack, 2.0f);
  other.draw_line({nan, 0.0f}, {10.0f, 10.0f}, colors::kBlack);
  other.draw_polyline({{0.0f, 0.0f}, {inf, 5.0f}, {5.0f, 5.0f}}, colors::kBlack);
  other.fill_circle({-100.0f, 5.0f}, 20.0f, kRed);
  other.fill_circle({nan, 5.0f}, 20.0f, kRed);
  other.fill_rect(-100.0f, -100.0f, 1e9f, 2.0f, kRed);
  other.fill_polygon({{-10.0f, -10.0f}, {100.0f, 0.0f}, {0.0f, 100.0f}}, kRed, 0.2f);
  other.draw_text(-40.0f, 25.0f, "clipped text", {3.0f, colors::kBlack});
  other.draw_text(25.0f, 25.0f, "clipped text",
                  {3.0f, colors::kBlack, tsdf_mcl::HAlign::kLeft, tsdf_mcl::VAlign::kTop, true});
  other.stroke_circle({29.0f, 29.0f}, 15.0f, kRed, 3.0f);
  other.blit(image, -20, 20);
  EXPECT_EQ(other.at(0, 0), kRed);  // the rectangle along the top edge, inside the image
}

TEST(ImageCanvas, HugeCoordinatesKeepTheVisiblePartsExact) {
  // Far beyond Cairo's fixed-point range (2^23 pixels): what shows is still the part inside, in the right place.
  Image image(100, 100);
  image.draw_line({10.5f, 10.5f}, {2e9f, 1e9f + 10.5f}, colors::kBlack, 2.0f);  // slope 1/2
  EXPECT_TRUE(dark(image.at(50, 30)));
  EXPECT_TRUE(dark(image.at(90, 50)));
  EXPECT_EQ(image.at(90, 60), colors::kWhite);
  image.draw_polyline({{95.5f, -1e30f}, {95.5f, 1e30f}}, kRed, 1.0f);
  EXPECT_EQ(image.at(95, 50), kRed);
  image.fill_polygon({{0.0f, 80.0f}, {1e12f, 80.0f}, {0.0f, 1e12f}}, kRed);  // a right angle at (0, 80)
  EXPECT_EQ(image.at(50, 90), kRed);
  EXPECT_EQ(image.at(50, 79), colors::kWhite);
  image.fill_rect(-1e30f, 70.0f, 1e30f, 71.0f, colors::kBlack);
  EXPECT_EQ(image.at(3, 70), colors::kBlack);

  // A dashed line billions of pixels long costs only its visible part, and its dashes stay in phase.
  Image dashes(100, 20);
  const auto start = std::chrono::steady_clock::now();
  dashes.draw_dashed_line({0.0f, 10.5f}, {4e9f, 10.5f}, colors::kBlack, 1.0f, 10.0f);
  dashes.draw_dashed_polyline({{-4e9f, 5.5f}, {4e9f, 5.5f}}, colors::kBlack, 1.0f, 10.0f);
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
  EXPECT_TRUE(dark(dashes.at(5, 10)));
  EXPECT_EQ(dashes.at(15, 10), colors::kWhite);
  EXPECT_TRUE(dark(dashes.at(25, 10)));

  // Circles and text far outside, or too large to draw, are left out without harm.
  image.fill_circle({1e8f, 1e8f}, 5.0f, kRed);
  image.stroke_circle({50.0f, 50.0f}, 1e9f, kRed, 3.0f);
  image.draw_text(1e9f, 1e9f, "far", {2.0f, kRed});
  image.draw_text(-1e7f, 50.0f, "huge", {1e6f, kRed});
  image.draw_text(10.0f, 10.0f, "inf", {std::numeric_limits<float>::infinity(), kRed});
  image.draw_text(10.0f, 10.0f, "nan", {std::numeric_limits<float>::quiet_NaN(), kRed});
  EXPECT_TRUE(dark(image.at(50, 30)));  // the black line is still there
  // Shapes larger than Cairo's range that cover the whole image fill it.
  Image covered(20, 20), wide(20, 20);
  covered.fill_circle({10.0f, 10.0f}, 3e38f, kRed);
  wide.draw_line({10.0f, 10.0f}, {11.0f, 10.0f}, kRed, 1e30f);
  EXPECT_EQ(count_not(covered, kRed), 0);
  EXPECT_EQ(count_not(wide, kRed), 0);
}

TEST(ImageCanvas, ComposeGridPlacesImagesInCells) {
  const Image a(10, 20, kRed), b(15, 5, colors::kBlack), c(5, 5, kRed);
  const Image grid = tsdf_mcl::compose_grid({a, b, c}, 2, 3);
  EXPECT_EQ(grid.width(), 2 * 15 + 3);
  EXPECT_EQ(grid.height(), 2 * 20 + 3);
  EXPECT_EQ(grid.at(0, 0), kRed);
  EXPECT_EQ(grid.at(18, 0), colors::kBlack);
  EXPECT_EQ(grid.at(0, 23), kRed);
  EXPECT_EQ(grid.at(12, 0), colors::kWhite);  // the gap
  EXPECT_THROW(tsdf_mcl::compose_grid({}, 2), Error);
}

TEST(ImagePng, RoundTripKeepsSizeAndPixels) {
  TempDir dir;
  Image image(31, 17, rgb_hex(0x123456));
  image.set_pixel(0, 0, kRed);
  image.set_pixel(30, 16, {1, 2, 3});
  tsdf_mcl::save_png(image, dir / "a.png");
  const Image back = tsdf_mcl::load_png(dir / "a.png");
  ASSERT_EQ(back.width(), 31);
  ASSERT_EQ(back.height(), 17);
  EXPECT_EQ(back.at(0, 0), kRed);
  EXPECT_EQ(back.at(30, 16), (Rgb{1, 2, 3}));
  EXPECT_EQ(back.at(15, 8), rgb_hex(0x123456));
  EXPECT_EQ(back.pixels(), image.pixels());
}

TEST(ImagePng, WriteAndReadErrorsNameTheFile) {
  TempDir dir;
  const Image image(4, 4);
  const auto missing_dir = dir / "no/such/dir/x.png";
  try {
    tsdf_mcl::save_png(image, missing_dir);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(missing_dir.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  EXPECT_THROW(tsdf_mcl::save_png(image, dir.path()), Error);  // a folder, not a file
  EXPECT_THROW(tsdf_mcl::save_png(Image(), dir / "empty.png"), Error);
  tsdf_mcl::test::write_bytes(dir / "junk.png", "not a png");
  try {
    tsdf_mcl::load_png(dir / "junk.png");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("junk.png"), std::string::npos) << e.what();
  }
  EXPECT_THROW(tsdf_mcl::load_png(dir / "missing.png"), Error);
}

TEST(ImageColor, ViridisEndsAndMix) {
  EXPECT_EQ(tsdf_mcl::viridis(0.0f), rgb_hex(0x440154));
  EXPECT_EQ(tsdf_mcl::viridis(1.0f), rgb_hex(0xfde725));
  EXPECT_EQ(tsdf_mcl::viridis(0.5f), rgb_hex(0x21918c));
  EXPECT_EQ(tsdf_mcl::viridis(-3.0f), tsdf_mcl::viridis(0.0f));
  EXPECT_EQ(tsdf_mcl::viridis(7.0f), tsdf_mcl::viridis(1.0f));
  EXPECT_EQ(tsdf_mcl::viridis(std::numeric_limits<float>::quiet_NaN()), tsdf_mcl::viridis(0.0f));
  // Brightness rises monotonically: heights read correctly even in greyscale.
  float last = -1.0f;
  for (int i = 0; i <= 20; ++i) {
    const Rgb c = tsdf_mcl::viridis(static_cast<float>(i) / 20.0f);
    const float luma = 0.299f * c.r + 0.587f * c.g + 0.114f * c.b;
    EXPECT_GT(luma, last);
    last = luma;
  }
  EXPECT_EQ(tsdf_mcl::mix(colors::kBlack, colors::kWhite, 0.5f), (Rgb{128, 128, 128}));
  EXPECT_EQ(tsdf_mcl::palette_color(0), tsdf_mcl::palette_color(10));
  EXPECT_NE(tsdf_mcl::palette_color(0), tsdf_mcl::palette_color(1));
}

TEST(ImageTopDown, WorldYUpMapsToPixelYDown) {
  const tsdf_mcl::TopDownTransform view({-2.0, 1.0}, {8.0, 6.0}, 0.05, {10, 20, 30, 40});
  EXPECT_EQ(view.width(), 10 + 200 + 30);
  EXPECT_EQ(view.height(), 20 + 100 + 40);
  EXPECT_EQ(view.area(), Eigen::Vector4i(10, 20, 210, 120));
  EXPECT_TRUE(view.to_pixel({-2.0, 1.0}).isApprox(Vector2f(10.0f, 120.0f)));
  EXPECT_TRUE(view.to_pixel({8.0, 6.0}).isApprox(Vector2f(210.0f, 20.0f)));
  const Vector2d p(3.3, 2.2);
  EXPECT_TRUE(view.to_world(view.to_pixel(p)).isApprox(p, 1e-6));
  const auto moved = view.moved_to({100, 7});
  EXPECT_TRUE((moved.to_pixel(p) - view.to_pixel(p)).isApprox(Vector2f(100.0f, 7.0f)));
  EXPECT_THROW(tsdf_mcl::TopDownTransform({0, 0}, {1, 1}, 0.0), Error);
  EXPECT_THROW(tsdf_mcl::TopDownTransform({0, 0}, {0, 1}, 0.1), Error);
  EXPECT_THROW(tsdf_mcl::TopDownTransform({0, 0}, {1e6, 1}, 0.001), Error);
}

TEST(ImageTopDown, ScaleBarHasANiceLengthAndLabel) {
  EXPECT_DOUBLE_EQ(tsdf_mcl::nice_number_at_most(7.3), 5.0);
  EXPECT_DOUBLE_EQ(tsdf_mcl::nice_number_at_most(1.0), 1.0);
  EXPECT_DOUBLE_EQ(tsdf_mcl::nice_number_at_most(0.19), 0.1);
  EXPECT_DOUBLE_EQ(tsdf_mcl::nice_number_at_most(2000.0), 2000.0);
  EXPECT_DOUBLE_EQ(tsdf_mcl::nice_number_at_most(4.99), 2.0);
  EXPECT_THROW(tsdf_mcl::nice_number_at_most(0.0), Error);

  Image image(300, 100);
  const tsdf_mcl::TopDownTransform view({0.0, 0.0}, {30.0, 10.0}, 0.1);
  tsdf_mcl::draw_scale_bar(image, view, 20.0f, 80.0f, 80.0f);  // at most 8 m: a 5 m bar, 50 pixels
  EXPECT_TRUE(dark(image.at(20, 79)));
  EXPECT_TRUE(dark(image.at(69, 79)));
  EXPECT_FALSE(dark(image.at(75, 79)));
  int label_ink = 0;
  for (int y = 50; y < 74; ++y) {
    for (int x = 20; x < 70; ++x) label_ink += dark(image.at(x, y));
  }
  EXPECT_GT(label_ink, 10);
}

TEST(ImageLegend, LegendAndColorbarDrawInsideTheirSize) {
  Image image(400, 200);
  const std::vector<tsdf_mcl::LegendEntry> entries = {
      {"ground truth", colors::kBlack, tsdf_mcl::LegendEntry::Symbol::kLine},
      {"estimate", kRed, tsdf_mcl::LegendEntry::Symbol::kDashedLine},
      {"particles", kRed, tsdf_mcl::LegendEntry::Symbol::kDot},
      {"unknown", Rgb{190, 190, 190}, tsdf_mcl::LegendEntry::Symbol::kBand},
      {"pose", kRed, tsdf_mcl::LegendEntry::Symbol::kArrow},
      {"start", kRed, tsdf_mcl::LegendEntry::Symbol::kRing}};
  const Vector2f size = tsdf_mcl::legend_size(entries, 1.5f);
  tsdf_mcl::draw_legend(image, 5.0f, 5.0f, entries, 1.5f);
  EXPECT_NE(image.at(5, 5), colors::kWhite);  // frame
  EXPECT_EQ(image.at(static_cast<int>(5.0f + size.x()) + 2, 10), colors::kWhite);
  EXPECT_EQ(image.at(10, static_cast<int>(5.0f + size.y()) + 2), colors::kWhite);

  const Vector2f bar =
      tsdf_mcl::draw_colorbar(image, 200.0f, 5.0f, 150.0f, tsdf_mcl::viridis, "0 m", "3 m", "height", 1.5f);
  EXPECT_GE(bar.x(), 150.0f);
  bool found_low = false, found_high = false;
  for (int y = 5; y < 5 + static_cast<int>(bar.y()); ++y) {
    found_low |= image.at(200, y) == tsdf_mcl::viridis(0.0f);
    found_high |= image.at(349, y) == tsdf_mcl::viridis(1.0f);
  }
  EXPECT_TRUE(found_low);
  EXPECT_TRUE(found_high);
}
