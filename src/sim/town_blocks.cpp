// What stands on a town block: rows of buildings around a courtyard, detached buildings (boxes, L shapes, set-back
// upper floors, rings), a tower on a podium, a ring with an archway, a park or a parking lot. Heights 3-25 m.
#include "town_blocks.hpp"

#include <algorithm>

namespace tsdf_mcl::sim {

namespace {

constexpr float kBase = kKerb - 0.05f;  // buildings stand from inside the block's slab
constexpr float kLowest = 3.0f, kHighest = 25.0f;
constexpr float kOverlap = 0.05f;  // neighbouring solids overlap instead of sharing a face

enum class Side { south, north, west, east };

bool along_x(Side s) { return s == Side::south || s == Side::north; }

Side opposite(Side s) {
  switch (s) {
    case Side::south:
      return Side::north;
    case Side::north:
      return Side::south;
    case Side::west:
      return Side::east;
    default:
      return Side::west;
  }
}

// r with its edge on `side` moved inwards by `by`.
Rect inset(Rect r, Side side, float by) {
  switch (side) {
    case Side::south:
      r.y0 += by;
      break;
    case Side::north:
      r.y1 -= by;
      break;
    case Side::west:
      r.x0 += by;
      break;
    case Side::east:
      r.x1 -= by;
      break;
  }
  return r;
}

float height_between(float h) { return std::clamp(h, kLowest, kHighest); }

// A building on one lot of a row: a box, or (one in four of those 9 m or more) lower floors over the whole lot and
// upper floors set back from the street.
void add_lot_building(TriangleMesh& mesh, const Rect& lot, Side street, float height, Rng& rng) {
  if (height >= 9.0f && rng.chance(0.25)) {
    const float lower = height * uniform(rng, 0.45f, 0.7f);
    const float back = uniform(rng, 2.0f, 4.0f);
    const float upper = height_between(height + uniform(rng, 0.0f, 4.0f));
    add_block(mesh, lot, kBase, lower);
    add_block(mesh, inset(lot, street, back), lower - kOverlap, upper);
    return;
  }
  add_block(mesh, lot, kBase, height);
}

// A row of buildings along a street, lot by lot (8-20 m wide), heights around `typical`; some lots stay empty,
// some fronts step back from the sidewalk, the backs vary.
void add_row(TriangleMesh& mesh, const Rect& strip, Side street, float typical, Rng& rng) {
  const bool ax = along_x(street);
  const float from = ax ? strip.x0 : strip.y0, to = ax ? strip.x1 : strip.y1;
  const float depth = ax ? strip.y1 - strip.y0 : strip.x1 - strip.x0;
  for (float a = from; to - a > 0.1f;) {
    float b = a + uniform(rng, 8.0f, 20.0f);
    if (to - b < 6.0f) b = to;
    // Lots reach into the next one: neighbours overlap rather than share a wall's face.
    const float end = std::min(b + kOverlap, to);
    Rect lot = ax ? Rect{a, strip.y0, end, strip.y1} : Rect{strip.x0, a, strip.x1, end};
    a = b;
    if (rng.chance(0.12)) continue;  // an empty lot: a gap into the courtyard
    const float height = height_between(typical * uniform(rng, 0.6f, 1.5f));
    const float front = rng.chance(0.3) ? uniform(rng, 0.3f, 1.5f) : 0.0f;
    const float back = depth * uniform(rng, 0.0f, 0.2f);
    lot = inset(inset(lot, street, front), opposite(street), back);
    add_lot_building(mesh, lot, street, height, rng);
  }
}

// Rows of buildings around the block's edge (9-14 m deep) leaving a courtyard; in a block too small for a courtyard,
// a row along its south and one along its north side, back to back where the block is narrow.
void add_rows(TriangleMesh& mesh, const Rect& inner, Rng& rng) {
  const float depth = uniform(rng, 9.0f, 14.0f);
  const float typical = uniform(rng, 6.0f, 18.0f);
  const float w = inner.x1 - inner.x0, h = inner.y1 - inner.y0;
  const float ns_depth = std::min(depth, h / 2 + kOverlap);
  add_row(mesh, {inner.x0, inner.y0, inner.x1, inner.y0 + ns_depth}, Side::south, typical, rng);
  add_row(mesh, {inner.x0, inner.y1 - ns_depth, inner.x1, inner.y1}, Side::north, typical, rng);
  if (w < 2 * depth + 6 || h < 2 * depth + 6) return;
  const float y0 = inner.y0 + depth - kOverlap, y1 = inner.y1 - depth + kOverlap;
  add_row(mesh, {inner.x0, y0, inner.x0 + depth, y1}, Side::west, typical, rng);
  add_row(mesh, {inner.x1 - depth, y0, inner.x1, y1}, Side::east, typical, rng);
}

// Four wings of one height around a courtyard, `wing` deep.
void add_ring(TriangleMesh& mesh, const Rect& r, float wing, float height) {
  add_block(mesh, {r.x0, r.y0, r.x1, r.y0 + wing}, kBase, height);
  add_block(mesh, {r.x0, r.y1 - wing, r.x1, r.y1}, kBase, height);
  add_block(mesh, {r.x0, r.y0, r.x0 + wing, r.y1}, kBase, height);
  add_block(mesh, {r.x1 - wing, r.y0, r.x1, r.y1}, kBase, height);
}

// An L: a wing along one x end and a wing along one y end of the footprint, of different heights.
void add_l_shape(TriangleMesh& mesh, const Rect& r, float height, Rng& rng) {
  const float wx = (r.x1 - r.x0) * uniform(rng, 0.35f, 0.6f);
  const float wy = (r.y1 - r.y0) * uniform(rng, 0.35f, 0.6f);
  const bool west = rng.chance(0.5), south = rng.chance(0.5);
  const float other = height_between(height * uniform(rng, 0.6f, 1.3f));
  add_block(mesh, south ? Rect{r.x0, r.y0, r.x1, r.y0 + wy} : Rect{r.x0, r.y1 - wy, r.x1, r.y1}, kBase, height);
  add_block(mesh, west ? Rect{r.x0, r.y0, r.x0 + wx, r.y1} : Rect{r.x1 - wx, r.y0, r.x1, r.y1}, kBase, other);
}

// One detached building on footprint r: a box, an L, set-back upper floors or a ring around a courtyard.
void add_detached_building(TriangleMesh& mesh, const Rect& r, Rng& rng) {
  const float u = uniform(rng, 0.0f, 1.0f);
  const float height = kLowest + (kHighest - kLowest) * u * u;  // mostly low, a few tall
  const double shape = rng.uniform();
  const float small = std::min(r.x1 - r.x0, r.y1 - r.y0);
  if (shape < 0.3) {
    add_l_shape(mesh, r, height, rng);
  } else if (shape < 0.55 && height >= 9.0f) {
    const float lower = height * uniform(rng, 0.4f, 0.7f);
    const float back = std::min(uniform(rng, 2.0f, 4.0f), small / 2 - 2.0f);
    add_block(mesh, r, kBase, lower);
    add_block(mesh, r.grown(-back), lower - kOverlap, height);
  } else if (shape < 0.7 && small >= 18.0f) {
    add_ring(mesh, r, uniform(rng, 5.0f, 7.0f), std::max(height, 6.0f));
  } else {
    add_block(mesh, r, kBase, height);
  }
}

// Three to six detached buildings (footprints 8-20 m) at least 3 m apart, as many as fit.
void add_detached(TriangleMesh& mesh, const Rect& inner, Rng& rng) {
  std::vector<Rect> placed;
  const auto count = 3 + rng.below(4);
  for (std::uint64_t k = 0, attempts = 0; k < count && attempts < 100; ++attempts) {
    const float w = std::min(uniform(rng, 8.0f, 20.0f), inner.x1 - inner.x0);
    const float h = std::min(uniform(rng, 8.0f, 20.0f), inner.y1 - inner.y0);
    const float x = uniform(rng, inner.x0, inner.x1 - w);
    const float y = uniform(rng, inner.y0, inner.y1 - h);
    const Rect r{x, y, x + w, y + h};
    if (std::any_of(placed.begin(), placed.end(), [&](const Rect& o) { return r.overlaps(o.grown(3.0f)); })) continue;
    placed.push_back(r);
    add_detached_building(mesh, r, rng);
    ++k;
  }
}

// A podium of shops (4-7 m) over most of the block and a tower (12-20 m square-ish, 15-25 m high) on it.
void add_tower(TriangleMesh& mesh, const Rect& inner, Rng& rng) {
  const Rect podium = inner.grown(-1.0f);
  const float podium_height = uniform(rng, 4.0f, 7.0f);
  add_block(mesh, podium, kBase, podium_height);
  const float w = std::min(uniform(rng, 12.0f, 20.0f), podium.x1 - podium.x0);
  const float h = std::min(uniform(rng, 12.0f, 20.0f), podium.y1 - podium.y0);
  const float x = uniform(rng, podium.x0, podium.x1 - w);
  const float y = uniform(rng, podium.y0, podium.y1 - h);
  const float height = uniform(rng, 15.0f, kHighest);
  add_block(mesh, {x, y, x + w, y + h}, podium_height - kOverlap, height);
}

// One building around a courtyard, 8-12 m deep and 8-16 m high, with a 4 m archway through one wing.
void add_courtyard(TriangleMesh& mesh, const Rect& inner, Rng& rng) {
  const Rect r = inner.grown(-uniform(rng, 0.0f, 1.0f));
  const float wing = uniform(rng, 8.0f, 12.0f);
  const float height = uniform(rng, 8.0f, 16.0f);
  if (r.x1 - r.x0 < 2 * wing + 14 || r.y1 - r.y0 < 2 * wing + 6) {
    add_rows(mesh, inner, rng);
    return;
  }
  const float gate = uniform(rng, r.x0 + wing + 2, r.x1 - wing - 6);
  const bool south = rng.chance(0.5);
  const float y0 = south ? r.y0 : r.y1 - wing, y1 = south ? r.y0 + wing : r.y1;
  add_block(mesh, {r.x0, y0, gate, y1}, kBase, height);
  add_block(mesh, {gate + 4, y0, r.x1, y1}, kBase, height);
  add_block(mesh, {gate - kOverlap, y0, gate + 4 + kOverlap, y1}, 4.0f, height);  // over the archway
  add_block(mesh, south ? Rect{r.x0, r.y1 - wing, r.x1, r.y1} : Rect{r.x0, r.y0, r.x1, r.y0 + wing}, kBase, height);
  add_block(mesh, {r.x0, r.y0, r.x0 + wing, r.y1}, kBase, height);
  add_block(mesh, {r.x1 - wing, r.y0, r.x1, r.y1}, kBase, height);
}

// Trees (at least 5 m apart), benches and, in half the parks, a pavilion.
void add_park(TriangleMesh& mesh, const Rect& inner, Rng& rng) {
  const Rect area = inner.grown(1.5f);
  std::vector<Eigen::Vector2f> trees;
  const auto count = 6 + rng.below(9);
  for (std::uint64_t attempt = 0; attempt < 80 && trees.size() < count; ++attempt) {
    const float x = uniform(rng, area.x0, area.x1), y = uniform(rng, area.y0, area.y1);
    const Eigen::Vector2f p(x, y);
    if (std::any_of(trees.begin(), trees.end(), [&](const Eigen::Vector2f& t) { return (t - p).norm() < 5.0f; }))
      continue;
    trees.push_back(p);
    add_tree(mesh, x, y, kKerb, rng);
  }
  const auto benches = 2 + rng.below(3);
  for (std::uint64_t k = 0; k < benches; ++k) {
    const float x = uniform(rng, area.x0 + 1, area.x1 - 1), y = uniform(rng, area.y0 + 1, area.y1 - 1);
    add_bench(mesh, x, y, kKerb, rng.chance(0.5));
  }
  if (rng.chance(0.5)) {
    const float cx = (inner.x0 + inner.x1) / 2, cy = (inner.y0 + inner.y1) / 2;
    for (const float dx : {-1.8f, 1.6f}) {
      for (const float dy : {-1.8f, 1.6f})
        add_block(mesh, {cx + dx, cy + dy, cx + dx + 0.2f, cy + dy + 0.2f}, kBase, 3.0f);
    }
    add_block(mesh, {cx - 2.2f, cy - 2.2f, cx + 2.2f, cy + 2.2f}, 2.95f, 3.2f);  // the pavilion's roof
  }
}

// Rows of parked cars (across the rows, 2.6 m bays, 60 % taken), light poles and a pay station.
void add_parking(TriangleMesh& mesh, const Rect& inner, Rng& rng) {
  for (float y = inner.y0 + 2.5f; y + 2.5f <= inner.y1; y += 7.5f) {
    for (float x = inner.x0 + 1.5f; x + 1.3f <= inner.x1; x += 2.6f) {
      if (rng.chance(0.6)) add_car(mesh, x, y, kKerb, false, rng);
    }
  }
  add_block(mesh, {inner.x0 - 1.5f, inner.y0 - 1.5f, inner.x0 - 0.3f, inner.y0 - 0.9f}, kBase, 1.7f);
  add_lamp(mesh, (inner.x0 + inner.x1) / 2, inner.y0 + 6.25f, kKerb, 1.0f, 0.0f);
}

}  // namespace

TriangleMesh block_contents(float w, float h, std::uint64_t design) {
  TriangleMesh mesh;
  Rng rng(design);
  const Rect inner{kSidewalk, kSidewalk, w - kSidewalk, h - kSidewalk};
  const double kind = rng.uniform();
  if (kind < 0.36) {
    add_rows(mesh, inner, rng);
  } else if (kind < 0.62) {
    add_detached(mesh, inner, rng);
  } else if (kind < 0.74) {
    add_tower(mesh, inner, rng);
  } else if (kind < 0.86) {
    add_courtyard(mesh, inner, rng);
  } else if (kind < 0.94) {
    add_park(mesh, inner, rng);
  } else {
    add_parking(mesh, inner, rng);
  }
  return mesh;
}

void add_car(TriangleMesh& mesh, float x, float y, float z, bool along_x, Rng& rng) {
  const bool van = rng.chance(1.0 / 7.0);
  const float half_length = van ? 2.6f : 2.2f, half_width = van ? 1.0f : 0.9f;
  const float top = van ? 2.1f : 1.0f;
  // In the car's own axes (u along it, v across), then laid along x or y.
  const auto box = [&](float u0, float u1, float v0, float v1, float z0, float z1) {
    add_block(mesh, along_x ? Rect{x + u0, y + v0, x + u1, y + v1} : Rect{x + v0, y + u0, x + v1, y + u1}, z + z0,
              z + z1);
  };
  box(-half_length, half_length, -half_width, half_width, 0.3f, top);  // the body, 0.3 m clear of the road
  for (const float axle : {-half_length + 0.85f, half_length - 0.85f}) {
    box(axle - 0.33f, axle + 0.33f, -half_width + 0.02f, half_width - 0.02f, -0.02f, 0.62f);  // wheels
  }
  if (!van) box(-1.4f, 0.9f, -half_width + 0.08f, half_width - 0.08f, top - kOverlap, 1.45f);  // the cabin
}

void add_tree(TriangleMesh& mesh, float x, float y, float z, Rng& rng) {
  const float r = uniform(rng, 1.2f, 1.7f);
  const float bottom = uniform(rng, 2.6f, 3.0f);
  const float top = bottom + uniform(rng, 2.8f, 4.0f);
  add_block(mesh, {x - 0.15f, y - 0.15f, x + 0.15f, y + 0.15f}, z - 0.05f, z + bottom + 0.3f);
  add_block(mesh, {x - r, y - 0.7f * r, x + r, y + 0.7f * r}, z + bottom, z + top);
  add_block(mesh, {x - 0.7f * r, y - r, x + 0.7f * r, y + r}, z + bottom + 0.3f, z + top + 0.4f);
}

void add_bench(TriangleMesh& mesh, float x, float y, float z, bool along_x) {
  const float l = 0.9f, d = 0.25f;
  add_block(mesh, along_x ? Rect{x - l, y - d, x + l, y + d} : Rect{x - d, y - l, x + d, y + l}, z - 0.05f, z + 0.45f);
}

void add_lamp(TriangleMesh& mesh, float x, float y, float z, float dx, float dy) {
  const float h = 0.09f;
  add_block(mesh, {x - h, y - h, x + h, y + h}, z - 0.05f, z + 7.0f);
  const float ex = x + 1.8f * dx, ey = y + 1.8f * dy;
  add_block(mesh, {std::min(x, ex) - 0.05f, std::min(y, ey) - 0.05f, std::max(x, ex) + 0.05f, std::max(y, ey) + 0.05f},
            z + 6.8f, z + 6.95f);
  add_block(mesh, {ex - 0.25f, ey - 0.25f, ex + 0.25f, ey + 0.25f}, z + 6.7f, z + 6.85f);  // the lamp head
}

}  // namespace tsdf_mcl::sim
