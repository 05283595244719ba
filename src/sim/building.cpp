#include "building.hpp"

#include <algorithm>
#include <cassert>

#include "shapes.hpp"

namespace tsdf_mcl::sim {

void add_block(TriangleMesh& mesh, const Rect& r, float z0, float z1) {
  add_box(mesh, Eigen::Vector3f(r.x0, r.y0, z0), Eigen::Vector3f(r.x1, r.y1, z1));
}

void add_wall(TriangleMesh& mesh, bool along_x, float line, float from, float to, float thickness, float z0, float z1,
              std::vector<Opening> openings) {
  std::sort(openings.begin(), openings.end(), [](const Opening& a, const Opening& b) { return a.from < b.from; });
  auto piece = [&](float a, float b, float bottom, float top) {
    if (b - a < 1e-3f) return;
    if (along_x) {
      add_block(mesh, {a, line - thickness / 2, b, line + thickness / 2}, bottom, top);
    } else {
      add_block(mesh, {line - thickness / 2, a, line + thickness / 2, b}, bottom, top);
    }
  };
  float cursor = from;
  for (const Opening& o : openings) {
    piece(cursor, o.from, z0, z1);
    piece(o.from, o.to, o.top, z1);
    cursor = o.to;
  }
  piece(cursor, to, z0, z1);
}

void add_shell(TriangleMesh& mesh, const Shell& s, const std::vector<Opening>& south_openings) {
  const float m = s.outer_wall;
  const float top = s.wall_top();
  if (s.floor_slab) add_block(mesh, {-m, -m, s.length + m, s.width + m}, -s.slab, 0.0f);
  if (s.ceiling_slab) add_block(mesh, {-m, -m, s.length + m, s.width + m}, s.ceiling, s.ceiling + s.slab);
  add_wall(mesh, true, -m / 2, -m, s.length + m, m, s.wall_bottom(), top, south_openings);
  add_block(mesh, {-m, s.width, s.length + m, s.width + m}, s.wall_bottom(), top);
  add_block(mesh, {-m, 0.0f, 0.0f, s.width}, s.wall_bottom(), top);
  add_block(mesh, {s.length, 0.0f, s.length + m, s.width}, s.wall_bottom(), top);
}

void append_half_turn(TriangleMesh& mesh, const TriangleMesh& part, const Eigen::Vector2f& centre) {
  TriangleMesh turned = part;
  for (Eigen::Vector3f& v : turned.vertices) v.head<2>() = 2.0f * centre - v.head<2>();
  mesh.append(turned);
}

void Furnisher::place_centre(const Rect& r, float height, bool legs) {
  assert(interior_.grown(-1.0f).contains(r) && !blocked(r));
  centre_.push_back(r);
  if (legs) {
    table(r, height);
  } else {
    add_block(mesh_, r, floor_ - 0.02f, floor_ + height);
  }
}

void Furnisher::line_walls(const std::vector<int>& kinds) {
  for (int side = 0; side < 4; ++side) {
    if (rng_.chance(0.2)) continue;
    const bool along_x = side < 2;
    const float start = along_x ? interior_.x0 : interior_.y0;
    const float end = along_x ? interior_.x1 : interior_.y1;
    float cursor = start + static_cast<float>(rng_.uniform(0.0, 0.6));
    while (cursor < end) {
      const int kind = kinds[rng_.below(kinds.size())];
      const Piece p = piece(kind);
      const Rect r = footprint(side, cursor, p.width, p.depth);
      cursor += p.width + static_cast<float>(rng_.uniform(0.05, 0.9));
      if (!interior_.contains(r) || blocked(r) || near_centre(r)) continue;
      placed_.push_back(r);
      if (p.legs) {
        table(r, p.height);
      } else {
        add_block(mesh_, r, floor_ + p.bottom - (p.bottom > 0.0f ? 0.0f : 0.02f), floor_ + p.height);
      }
    }
  }
}

Furnisher::Piece Furnisher::piece(int kind) {
  auto u = [&](double a, double b) { return static_cast<float>(rng_.uniform(a, b)); };
  switch (kind) {
    case kDesk:
      return {u(1.4, 1.8), 0.8f, 0.74f, 0.0f, true};
    case kTallCabinet:
      return {u(0.8, 1.0), 0.45f, u(1.9, 2.1), 0.0f, false};
    case kSideboard:
      return {u(0.8, 1.6), 0.45f, u(0.75, 0.85), 0.0f, false};
    case kShelf:
      return {u(0.8, 1.0), 0.35f, u(1.8, 2.2), 0.0f, false};
    case kCounter:
      return {u(1.8, 3.0), 0.6f, 0.9f, 0.0f, false};
    default:
      return {u(1.2, 2.0), 0.03f, u(1.9, 2.0), 0.9f, false};  // whiteboard hangs on the wall
  }
}

Rect Furnisher::footprint(int side, float at, float width, float depth) const {
  switch (side) {
    case 0:
      return {at, interior_.y0, at + width, interior_.y0 + depth};
    case 1:
      return {at, interior_.y1 - depth, at + width, interior_.y1};
    case 2:
      return {interior_.x0, at, interior_.x0 + depth, at + width};
    default:
      return {interior_.x1 - depth, at, interior_.x1, at + width};
  }
}

bool Furnisher::blocked(const Rect& r) const {
  for (const Rect& o : keep_out_) {
    if (r.overlaps(o)) return true;
  }
  for (const auto* pieces : {&placed_, &centre_}) {
    for (const Rect& o : *pieces) {
      if (r.overlaps(o.grown(0.05f))) return true;
    }
  }
  return false;
}

bool Furnisher::near_centre(const Rect& r) const {
  for (const Rect& o : centre_) {
    if (r.overlaps(o.grown(1.0f))) return true;
  }
  return false;
}

void Furnisher::table(const Rect& r, float height) {
  const float leg = 0.05f, top = 0.03f, inset = 0.04f;
  add_block(mesh_, r, floor_ + height - top, floor_ + height);
  for (int i = 0; i < 4; ++i) {
    const float x = (i & 1) ? r.x1 - inset - leg : r.x0 + inset;
    const float y = (i & 2) ? r.y1 - inset - leg : r.y0 + inset;
    add_block(mesh_, {x, y, x + leg, y + leg}, floor_ - 0.02f, floor_ + height - top + 0.01f);
  }
}

}  // namespace tsdf_mcl::sim
