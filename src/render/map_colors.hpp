#pragma once
// What the map raster and the map view share (private to src/render/): the map's colours and the metres format of
// their scales.
#include <cstdio>
#include <string>

#include "tsdf_mcl/render/image.hpp"

namespace tsdf_mcl::render {

constexpr Rgb kUnknownColor = rgb_hex(0xbdbdbd);
constexpr Rgb kFreeColor = colors::kWhite;
constexpr Rgb kNearSurfaceColor = rgb_hex(0xc6dbef);
constexpr Rgb kSurfaceColor = rgb_hex(0x252525);
constexpr Rgb kInsideColor = rgb_hex(0xd6a5a5);
constexpr Rgb kDeepInsideColor = rgb_hex(0x8c4a4a);

// Viridis reversed, so that tall structure (walls) is dark and stands out like the walls of a floor plan while low
// clutter is light; without viridis' brightest tenth, which would vanish on white free space.
inline Rgb height_color(float t) { return viridis(0.9f * (1.0f - t)); }

inline std::string format_metres(float v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.2f m", static_cast<double>(v));
  return text;
}

}  // namespace tsdf_mcl::render
