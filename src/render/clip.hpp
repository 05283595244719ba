#pragma once
// Clipping in double precision, before coordinates are handed to Cairo (whose fixed-point paths end at +-2^23
// pixels) or narrowed to float: the part of a line or polygon inside a box keeps its exact direction.
#include <Eigen/Core>
#include <algorithm>
#include <utility>
#include <vector>

namespace tsdf_mcl::render {

// Clips the segment a-b to the box [lo, hi] in place (Liang-Barsky); false if nothing of it is inside. A cut end lies
// exactly on the box's side, its other coordinate interpolated from the nearer end, so that the visible part of a
// line with ends far away (1e30 pixels) stays where it belongs.
inline bool clip_segment(Eigen::Vector2d& a, Eigen::Vector2d& b, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  const Eigen::Vector2d d = b - a;
  double t[2] = {0.0, 1.0};  // entry and exit parameter
  int axis[2] = {-1, -1};    // the side each was cut at: axis and bound
  double bound[2] = {0.0, 0.0};
  for (int k = 0; k < 2; ++k) {
    for (const bool upper : {false, true}) {
      const double side = upper ? hi[k] : lo[k];
      if (d[k] == 0.0) {
        if (upper ? a[k] > side : a[k] < side) return false;
        continue;
      }
      const double s = (side - a[k]) / d[k];
      const int end = upper == (d[k] > 0.0) ? 1 : 0;  // moving up, the line enters through lo and leaves through hi
      if (end == 0 ? s > t[0] : s < t[1]) {
        t[end] = s;
        axis[end] = k;
        bound[end] = side;
      }
    }
  }
  // A visible segment's t[0] may pass t[1] by rounding where its ends are astronomically far apart.
  if (t[0] > t[1] + 1e-9) return false;
  Eigen::Vector2d cut[2] = {a, b};
  for (int end = 0; end < 2; ++end) {
    if (axis[end] < 0) continue;
    const int k = axis[end], o = 1 - k;
    const Eigen::Vector2d& from = t[end] < 0.5 ? a : b;
    cut[end][k] = bound[end];
    cut[end][o] = from[o] + (bound[end] - from[k]) * (d[o] / d[k]);
  }
  a = cut[0];
  b = cut[1];
  return true;
}

// Sutherland-Hodgman: the polygon cut to the box. Edges along the box's sides may appear; under the even-odd rule
// they cover nothing inside the box.
inline std::vector<Eigen::Vector2d> clip_polygon(std::vector<Eigen::Vector2d> polygon, const Eigen::Vector2d& lo,
                                                 const Eigen::Vector2d& hi) {
  for (int side = 0; side < 4 && !polygon.empty(); ++side) {
    const int axis = side % 2;
    const bool upper = side >= 2;
    const double limit = upper ? hi[axis] : lo[axis];
    auto inside = [&](const Eigen::Vector2d& p) { return upper ? p[axis] <= limit : p[axis] >= limit; };
    std::vector<Eigen::Vector2d> out;
    for (std::size_t i = 0; i < polygon.size(); ++i) {
      const Eigen::Vector2d& a = polygon[i];
      const Eigen::Vector2d& b = polygon[(i + 1) % polygon.size()];
      if (inside(a)) out.push_back(a);
      if (inside(a) != inside(b)) out.push_back(a + (b - a) * ((limit - a[axis]) / (b[axis] - a[axis])));
    }
    polygon = std::move(out);
  }
  return polygon;
}

}  // namespace tsdf_mcl::render
