// The built-in town: open-air streets between blocks of buildings on a ground slab, no roof (docs/simulator.md).
//
// Plan (x east, y north, 0..size m, ground z = 0): a verge 4 m wide with a hedge and trees around the town; inside it
// a grid of carriageways 8-14 m wide at ground level between blocks raised 0.15 m (the kerb). Blocks measure 28-52 m
// (a few standard sizes; the last of each row and column takes what is left) and hold what town_blocks.cpp builds
// 3 m in from their edges (the sidewalk); a third of them take the design of an earlier block of their size, so
// some streets look alike. One block per 30,000 m^2 of town (at least one) is a plaza raised 0.9 m, reached from the
// streets on its west and east sides by 6 deg ramps. Each street has one of four styles (lamp spacing, trees, which
// kerbs have parked cars), the same along every block it passes; signs, bins and benches stand on the sidewalks;
// cars park along the kerbs, never at a corner or in front of a ramp.
#include <array>
#include <cmath>
#include <iterator>

#include "shapes.hpp"
#include "town_blocks.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sim/simulator.hpp"

namespace tsdf_mcl::sim {

namespace {

using Eigen::Vector2f;

constexpr float kSlab = 0.3f;   // the ground slab under everything, its top at z = 0
constexpr float kVerge = 4.0f;  // the raised strip around the town
// Plazas stay lower than the robot (1 m): the traversable floor is the lowest surface with the robot's headroom
// above it, and a taller solid would offer the ground slab inside it.
constexpr float kPlazaHeight = 0.9f;
constexpr float kRampWidth = 4.0f;
constexpr float kRampRun = 8.56f;  // 0.9 m up at 6 deg
constexpr float kRoadWidths[] = {8.0f, 10.0f, 10.0f, 12.0f, 14.0f};
constexpr float kBlockSizes[] = {28.0f, 36.0f, 44.0f, 52.0f};
constexpr double kMinSize = 80.0, kMaxSize = 400.0;
constexpr double kAreaPerPlaza = 30000.0;  // m^2
constexpr double kLookAlike = 0.35;        // the chance that a block copies an earlier one of its size
constexpr int kStyles = 4;                 // street styles per town

// One random stream per purpose of the town's seed.
enum Stream : std::uint64_t { kGrid = 1, kDesigns = 2, kStyleChoice = 3, kPlazas = 4, kVerges = 5, kBlocks = 100 };

struct Span {
  float from, to;
};

// The carriageways across one axis: road, block, road, ... road between the verges; blocks take standard sizes and
// the last one what is left.
std::vector<Span> road_spans(float size, Rng& rng) {
  const auto road_width = [&] { return kRoadWidths[rng.below(std::size(kRoadWidths))]; };
  const float end = size - kVerge;
  const float first = road_width();
  std::vector<Span> roads{{kVerge, kVerge + first}};
  for (float pos = kVerge + first;;) {
    const float block = kBlockSizes[rng.below(std::size(kBlockSizes))];
    const float next = road_width();
    const float remaining = end - pos;
    if (block + next > remaining) {
      if (remaining - next >= kBlockSizes[0]) {
        roads.push_back({end - next, end});
      } else {  // no room for another block: the last one grows to the verge
        const float width = roads.back().to - roads.back().from;
        roads.back() = {end - width, end};
      }
      return roads;
    }
    pos += block;
    roads.push_back({pos, pos + next});
    pos += next;
  }
}

// How a street is furnished, the same along every block it passes.
struct StreetStyle {
  float lamp_spacing;  // m along the kerb
  bool trees;          // a tree halfway between lamps
  bool parking[2];     // cars along the kerb on the street's low (west or south) and high side
};

std::array<StreetStyle, kStyles> street_styles(Rng& rng) {
  std::array<StreetStyle, kStyles> styles{};
  for (StreetStyle& s : styles) {
    s.lamp_spacing = uniform(rng, 16.0f, 28.0f);
    s.trees = rng.chance(0.5);
    s.parking[0] = rng.chance(0.6);
    s.parking[1] = rng.chance(0.6);
  }
  return styles;
}

// A block's side along a street.
struct Kerb {
  bool along_x;    // the kerb runs along x (the block's south or north side)
  float line;      // its y (or x)
  float inward;    // +1 or -1: the block lies on this side of the line
  float from, to;  // the side's extent along the kerb
  float top;       // the sidewalk's height
  Vector2f at(float along, float in) const {
    const float across = line + inward * in;
    return along_x ? Vector2f(along, across) : Vector2f(across, along);
  }
};

bool inside(const std::vector<Span>& spans, float t) {
  for (const Span& s : spans) {
    if (t >= s.from && t <= s.to) return true;
  }
  return false;
}

// A bin, a sign post with its plate or a bench on the sidewalk, t along the kerb.
void add_street_item(TriangleMesh& mesh, const Kerb& k, float t, Rng& rng) {
  const auto kind = rng.below(3);
  if (kind == 0) {
    const Vector2f p = k.at(t, 0.5f);
    add_block(mesh, {p.x() - 0.25f, p.y() - 0.25f, p.x() + 0.25f, p.y() + 0.25f}, k.top - 0.05f, k.top + 0.9f);
  } else if (kind == 1) {
    const Vector2f p = k.at(t, 0.4f);
    add_block(mesh, {p.x() - 0.04f, p.y() - 0.04f, p.x() + 0.04f, p.y() + 0.04f}, k.top - 0.05f, k.top + 2.6f);
    const Vector2f a = k.at(t - 0.3f, 0.31f), b = k.at(t + 0.3f, 0.37f);
    add_block(mesh, {std::min(a.x(), b.x()), std::min(a.y(), b.y()), std::max(a.x(), b.x()), std::max(a.y(), b.y())},
              k.top + 1.9f, k.top + 2.5f);
  } else {
    const Vector2f p = k.at(t, 2.4f);
    add_bench(mesh, p.x(), p.y(), k.top, k.along_x);
  }
}

// Lamps (arms over the road) at the style's spacing from the side's start, trees halfway between them, up to three
// signs, bins or benches, and cars in 6 m bays along the kerb (55 % taken) from 7 m after the corner. Nothing stands
// in `clear`, no car in `no_cars` (along the kerb).
void furnish_kerb(TriangleMesh& mesh, const Kerb& k, const StreetStyle& style, bool parking,
                  const std::vector<Span>& clear, const std::vector<Span>& no_cars, Rng& rng) {
  std::vector<float> taken;
  const float arm_x = k.along_x ? 0.0f : -k.inward, arm_y = k.along_x ? -k.inward : 0.0f;
  for (float t = k.from + 2.5f; t <= k.to - 2.5f; t += style.lamp_spacing) {
    if (!inside(clear, t)) {
      const Vector2f p = k.at(t, 0.6f);
      add_lamp(mesh, p.x(), p.y(), k.top, arm_x, arm_y);
      taken.push_back(t);
    }
    const float between = t + style.lamp_spacing / 2;
    if (style.trees && between <= k.to - 3.0f && !inside(clear, between)) {
      const Vector2f p = k.at(between, 1.5f);
      add_tree(mesh, p.x(), p.y(), k.top, rng);
      taken.push_back(between);
    }
  }
  const auto items = rng.below(4);
  for (std::uint64_t i = 0; i < items; ++i) {
    const float t = uniform(rng, k.from + 3.0f, k.to - 3.0f);
    bool free = !inside(clear, t);
    for (const float o : taken) free = free && std::abs(o - t) > 1.5f;
    if (!free) continue;
    add_street_item(mesh, k, t, rng);
    taken.push_back(t);
  }
  if (!parking) return;
  for (float t = k.from + 7.0f; t + 7.0f <= k.to; t += 6.0f) {
    const float shift = uniform(rng, -0.4f, 0.4f);
    if (inside(no_cars, t) || !rng.chance(0.55)) continue;
    const Vector2f p = k.at(t + shift, -1.3f);
    add_car(mesh, p.x(), p.y(), 0.0f, k.along_x, rng);
  }
}

// A plaza 0.9 m up over the whole block, entered by a ramp lane (4 m wide, 6 deg) from the street on its west and
// on its east side; between the ramps a path, around it trees, benches, lamps, a kiosk and a monument.
void add_plaza(TriangleMesh& mesh, const Rect& b, Rng& rng) {
  const float mid = (b.y0 + b.y1) / 2;
  const float lane0 = mid - kRampWidth / 2, lane1 = mid + kRampWidth / 2, h = kPlazaHeight;
  // The ramp lanes' walls overlap the lanes by 5 cm rather than share their faces.
  add_block(mesh, {b.x0, b.y0, b.x1, lane0 + 0.05f}, -0.1f, h);
  add_block(mesh, {b.x0, lane1 - 0.05f, b.x1, b.y1}, -0.1f, h);
  add_block(mesh, {b.x0 + kRampRun, lane0, b.x1 - kRampRun, lane1}, -0.1f, h);
  add_prism_xz(mesh,
               {Vector2f(b.x0, -0.1f), Vector2f(b.x0 + kRampRun + 0.2f, -0.1f), Vector2f(b.x0 + kRampRun + 0.2f, h),
                Vector2f(b.x0 + kRampRun, h), Vector2f(b.x0, 0.0f)},
               lane0, lane1);
  add_prism_xz(mesh,
               {Vector2f(b.x1 - kRampRun - 0.2f, -0.1f), Vector2f(b.x1, -0.1f), Vector2f(b.x1, 0.0f),
                Vector2f(b.x1 - kRampRun, h), Vector2f(b.x1 - kRampRun - 0.2f, h)},
               lane0, lane1);
  const float cx = (b.x0 + b.x1) / 2;
  add_block(mesh, {cx - 0.75f, mid + 5.25f, cx + 0.75f, mid + 6.75f}, h - 0.05f, h + 1.0f);  // the monument
  add_block(mesh, {cx - 0.25f, mid + 5.75f, cx + 0.25f, mid + 6.25f}, h + 0.95f, h + 5.0f);
  const float kiosk_x = uniform(rng, b.x0 + kRampRun + 2.0f, b.x1 - kRampRun - 5.0f);
  add_block(mesh, {kiosk_x, mid - 7.0f, kiosk_x + 3.0f, mid - 4.0f}, h - 0.05f, h + 2.8f);
  for (float x = b.x0 + 4.0f; x < b.x1 - 3.0f; x += 9.0f) {
    for (float y = b.y0 + 4.0f; y < b.y1 - 3.0f; y += 9.0f) {
      const float jx = uniform(rng, -1.5f, 1.5f), jy = uniform(rng, -1.5f, 1.5f);
      const Vector2f p(x + jx, y + jy);
      const bool path = std::abs(p.y() - mid) < 4.0f;
      const bool monument = std::abs(p.x() - cx) < 3.0f && std::abs(p.y() - mid - 6.0f) < 3.0f;
      const bool kiosk = p.x() > kiosk_x - 2.5f && p.x() < kiosk_x + 5.5f && p.y() > mid - 9.5f;
      if (path || monument || kiosk || !rng.chance(0.75)) continue;
      add_tree(mesh, p.x(), p.y(), h, rng);
    }
  }
  for (float x = b.x0 + kRampRun + 3.0f; x < b.x1 - kRampRun - 2.0f; x += 8.0f) {
    add_bench(mesh, x, mid + 3.0f, h, true);
    add_lamp(mesh, x + 2.0f, mid - 2.6f, h, 0.0f, 1.0f);
  }
}

// The verge around the town: a raised strip with a hedge along the outer edge and trees.
void add_verge(TriangleMesh& mesh, float size, Rng& rng) {
  const float s = size, hedge = 1.2f;
  for (const Rect& r :
       {Rect{0, 0, s, kVerge}, Rect{0, s - kVerge, s, s}, Rect{0, 0, kVerge, s}, Rect{s - kVerge, 0, s, s}})
    add_block(mesh, r, -0.1f, kKerb);
  for (const Rect& r : {Rect{0, 0, s, hedge}, Rect{0, s - hedge, s, s}, Rect{0, 0, hedge, s}, Rect{s - hedge, 0, s, s}})
    add_block(mesh, r, kKerb - 0.05f, 1.6f);
  for (float t = 6.0f; t < s - 6.0f; t += uniform(rng, 10.0f, 16.0f)) {
    add_tree(mesh, t, 2.7f, kKerb, rng);
    add_tree(mesh, t, s - 2.7f, kKerb, rng);
    add_tree(mesh, 2.7f, t, kKerb, rng);
    add_tree(mesh, s - 2.7f, t, kKerb, rng);
  }
}

struct Block {
  Rect r;
  std::size_t ix, iy;  // between the north-south roads ix and ix + 1, the east-west roads iy and iy + 1
  bool plaza = false;
};

// Which blocks are plazas: one per kAreaPerPlaza of town, among the blocks at least 30 m wide.
void choose_plazas(std::vector<Block>& blocks, float size, Rng& rng) {
  std::vector<std::size_t> candidates;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    if (blocks[i].r.x1 - blocks[i].r.x0 >= 30.0f) candidates.push_back(i);
  }
  const auto wanted = static_cast<std::size_t>(std::max(1.0, std::round(size * size / kAreaPerPlaza)));
  for (std::size_t k = 0; k < wanted && !candidates.empty(); ++k) {
    const auto pick = static_cast<std::ptrdiff_t>(rng.below(candidates.size()));
    blocks[candidates[static_cast<std::size_t>(pick)]].plaza = true;
    candidates.erase(candidates.begin() + pick);
  }
}

// Each block's design key: its own, or (kLookAlike) that of an earlier block of its size.
std::vector<std::uint64_t> block_designs(const std::vector<Block>& blocks, std::uint64_t seed, Rng& rng) {
  std::vector<std::uint64_t> designs;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const Rect& r = blocks[i].r;
    std::vector<std::size_t> twins;
    for (std::size_t j = 0; j < i; ++j) {
      const Rect& o = blocks[j].r;
      if (!blocks[j].plaza && std::abs((o.x1 - o.x0) - (r.x1 - r.x0)) < 1e-3f &&
          std::abs((o.y1 - o.y0) - (r.y1 - r.y0)) < 1e-3f)
        twins.push_back(j);
    }
    const bool copy = rng.chance(kLookAlike);
    designs.push_back(copy && !twins.empty() ? designs[twins[rng.below(twins.size())]] : mix_key(seed, kBlocks + i));
  }
  return designs;
}

// The four kerbs of a block, with the style and parking side of the street each one faces.
void furnish_block(TriangleMesh& mesh, const Block& b, const std::vector<StreetStyle>& ns_styles,
                   const std::vector<StreetStyle>& ew_styles, std::uint64_t key) {
  Rng rng(key);
  const Rect& r = b.r;
  const float top = b.plaza ? kPlazaHeight : kKerb;
  const float mid = (r.y0 + r.y1) / 2;
  // The plaza's ramps: no furniture in front of them, no car within 4 m.
  const std::vector<Span> ramp = b.plaza ? std::vector<Span>{{mid - 3.0f, mid + 3.0f}} : std::vector<Span>{};
  const std::vector<Span> ramp_cars = b.plaza ? std::vector<Span>{{mid - 6.0f, mid + 6.0f}} : std::vector<Span>{};
  // South: the street below is ew road iy, the block on its high side; north: road iy + 1, its low side.
  const StreetStyle& south = ew_styles[b.iy];
  const StreetStyle& north = ew_styles[b.iy + 1];
  const StreetStyle& west = ns_styles[b.ix];
  const StreetStyle& east = ns_styles[b.ix + 1];
  furnish_kerb(mesh, {true, r.y0, 1.0f, r.x0, r.x1, top}, south, south.parking[1], {}, {}, rng);
  furnish_kerb(mesh, {true, r.y1, -1.0f, r.x0, r.x1, top}, north, north.parking[0], {}, {}, rng);
  furnish_kerb(mesh, {false, r.x0, 1.0f, r.y0, r.y1, top}, west, west.parking[1], ramp, ramp_cars, rng);
  furnish_kerb(mesh, {false, r.x1, -1.0f, r.y0, r.y1, top}, east, east.parking[0], ramp, ramp_cars, rng);
}

std::vector<StreetStyle> styles_of_roads(std::size_t roads, const std::array<StreetStyle, kStyles>& styles, Rng& rng) {
  std::vector<StreetStyle> out;
  for (std::size_t i = 0; i < roads; ++i) out.push_back(styles[rng.below(kStyles)]);
  return out;
}

}  // namespace

BuiltInScene town_scene(std::uint64_t seed, double size_m) {
  if (!(size_m >= kMinSize && size_m <= kMaxSize)) {
    throw Error("the town's size must be in [80, 400] m, got " + std::to_string(size_m));
  }
  const auto size = static_cast<float>(size_m);
  Rng grid_rng(mix_key(seed, kGrid));
  const std::vector<Span> ns_roads = road_spans(size, grid_rng);  // running north, spans in x
  const std::vector<Span> ew_roads = road_spans(size, grid_rng);  // running east, spans in y
  std::vector<Block> blocks;
  for (std::size_t iy = 0; iy + 1 < ew_roads.size(); ++iy) {
    for (std::size_t ix = 0; ix + 1 < ns_roads.size(); ++ix) {
      blocks.push_back({{ns_roads[ix].to, ew_roads[iy].to, ns_roads[ix + 1].from, ew_roads[iy + 1].from}, ix, iy});
    }
  }
  Rng plaza_rng(mix_key(seed, kPlazas));
  choose_plazas(blocks, size, plaza_rng);
  Rng design_rng(mix_key(seed, kDesigns));
  const std::vector<std::uint64_t> designs = block_designs(blocks, seed, design_rng);
  Rng style_rng(mix_key(seed, kStyleChoice));
  const std::array<StreetStyle, kStyles> styles = street_styles(style_rng);
  const std::vector<StreetStyle> ns_styles = styles_of_roads(ns_roads.size(), styles, style_rng);
  const std::vector<StreetStyle> ew_styles = styles_of_roads(ew_roads.size(), styles, style_rng);

  BuiltInScene scene;
  TriangleMesh& mesh = scene.mesh;
  add_block(mesh, {0.0f, 0.0f, size, size}, -kSlab, 0.0f);
  Rng verge_rng(mix_key(seed, kVerges));
  add_verge(mesh, size, verge_rng);
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    const Block& b = blocks[i];
    if (b.plaza) {
      Rng rng(mix_key(designs[i], 1));
      add_plaza(mesh, b.r, rng);
    } else {
      add_block(mesh, b.r, -0.1f, kKerb);
      TriangleMesh contents = block_contents(b.r.x1 - b.r.x0, b.r.y1 - b.r.y0, designs[i]);
      for (Eigen::Vector3f& v : contents.vertices) v += Eigen::Vector3f(b.r.x0, b.r.y0, 0.0f);
      mesh.append(contents);
    }
    furnish_block(mesh, b, ns_styles, ew_styles, mix_key(seed, kBlocks + blocks.size() + i));
  }
  for (const Span& s : ns_roads) scene.streets.emplace_back(Vector2f(s.from, kVerge), Vector2f(s.to, size - kVerge));
  for (const Span& s : ew_roads) scene.streets.emplace_back(Vector2f(kVerge, s.from), Vector2f(size - kVerge, s.to));
  scene.open_air = true;
  return scene;
}

}  // namespace tsdf_mcl::sim
