// Mesh -> TSDF. Three steps:
//  1. band blocks: every block whose voxel centres may lie within the truncation of a triangle (a conservative
//     triangle/box overlap test);
//  2. per band block, the exact signed distance of each voxel: the closest triangle among those near the block,
//     the sign from the angle-weighted pseudo-normal of the closest feature (face, edge or vertex; Baerentzen &
//     Aanaes 2005), which stays consistent on meshes that are not watertight;
//  3. the blocks outside the band: 6-connected components of them are enclosed by band blocks, so each
//     component lies on one side of the surface; the band voxels facing it vote on which side.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_map>
#include <vector>

#include "block_face.hpp"
#include "build_budget.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"

namespace tsdf_mcl {
namespace {

using Eigen::Vector3f;
using Eigen::Vector3i;

enum class Feature { kFace, kVertex0, kVertex1, kVertex2, kEdge01, kEdge12, kEdge20 };

struct Triangle {
  Vector3f a, b, c;
  Vector3f lo, hi;  // bounding box
  Vector3f normal;  // unit
  std::array<int, 3> vertex;
  std::array<int, 3> edge;  // edges (0,1), (1,2), (2,0)
};

// Closest point on a triangle and the feature it lies on (Ericson, Real-Time Collision Detection, 5.1.5).
Vector3f closest_on_triangle(const Vector3f& p, const Triangle& t, Feature& feature) {
  const Vector3f ab = t.b - t.a, ac = t.c - t.a, ap = p - t.a;
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0f && d2 <= 0.0f) {
    feature = Feature::kVertex0;
    return t.a;
  }
  const Vector3f bp = p - t.b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0f && d4 <= d3) {
    feature = Feature::kVertex1;
    return t.b;
  }
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) {
    feature = Feature::kEdge01;
    return t.a + ab * (d1 / (d1 - d3));
  }
  const Vector3f cp = p - t.c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0f && d5 <= d6) {
    feature = Feature::kVertex2;
    return t.c;
  }
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) {
    feature = Feature::kEdge20;
    return t.a + ac * (d2 / (d2 - d6));
  }
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0.0f && (d4 - d3) >= 0.0f && (d5 - d6) >= 0.0f) {
    feature = Feature::kEdge12;
    return t.b + (t.c - t.b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  }
  feature = Feature::kFace;
  const float denom = 1.0f / (va + vb + vc);
  return t.a + ab * (vb * denom) + ac * (vc * denom);
}

// Triangle / axis-aligned box overlap by the separating axis theorem (Akenine-Moeller 2001).
bool overlaps(const Triangle& t, const Vector3f& center, float half) {
  const Vector3f v0 = t.a - center, v1 = t.b - center, v2 = t.c - center;
  for (int a = 0; a < 3; ++a) {
    if (t.lo[a] > center[a] + half || t.hi[a] < center[a] - half) return false;
  }
  if (std::abs(t.normal.dot(v0)) > half * t.normal.cwiseAbs().sum()) return false;
  const Vector3f edges[3] = {v1 - v0, v2 - v1, v0 - v2};
  for (const Vector3f& e : edges) {
    for (int a = 0; a < 3; ++a) {
      // axis = e x unit(a)
      Vector3f axis = Vector3f::Zero();
      axis[(a + 1) % 3] = e[(a + 2) % 3];
      axis[(a + 2) % 3] = -e[(a + 1) % 3];
      const float p0 = axis.dot(v0), p1 = axis.dot(v1), p2 = axis.dot(v2);
      const float r = half * axis.cwiseAbs().sum();
      if (std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r) return false;
    }
  }
  return true;
}

// A lower bound of the distance from any point of the box to the triangle: orders the candidates of a block
// so that the per-voxel search can stop early.
float distance_lower_bound(const Triangle& t, const Vector3f& center, float half) {
  const Vector3f gap = ((t.lo - center).cwiseMax(center - t.hi).array() - half).cwiseMax(0.0f);
  const float plane = std::max(0.0f, std::abs(t.normal.dot(center - t.a)) - half * t.normal.cwiseAbs().sum());
  return std::max(gap.norm(), plane);
}

struct Surface {
  std::vector<Triangle> triangles;
  std::vector<Vector3f> vertex_normal;  // angle-weighted pseudo-normals (unnormalized: only signs are used)
  std::vector<Vector3f> edge_normal;

  const Vector3f& pseudo_normal(const Triangle& t, Feature f) const {
    switch (f) {
      case Feature::kFace:
        return t.normal;
      case Feature::kVertex0:
        return vertex_normal[static_cast<std::size_t>(t.vertex[0])];
      case Feature::kVertex1:
        return vertex_normal[static_cast<std::size_t>(t.vertex[1])];
      case Feature::kVertex2:
        return vertex_normal[static_cast<std::size_t>(t.vertex[2])];
      case Feature::kEdge01:
        return edge_normal[static_cast<std::size_t>(t.edge[0])];
      case Feature::kEdge12:
        return edge_normal[static_cast<std::size_t>(t.edge[1])];
      case Feature::kEdge20:
        return edge_normal[static_cast<std::size_t>(t.edge[2])];
    }
    return t.normal;
  }
};

Surface prepare_surface(const TriangleMesh& mesh) {
  const auto n_vertices = static_cast<int>(mesh.vertices.size());
  for (const Vector3f& v : mesh.vertices) {
    if (!v.allFinite()) throw Error("mesh has a non-finite vertex");
  }
  Surface s;
  s.vertex_normal.assign(mesh.vertices.size(), Vector3f::Zero());
  std::unordered_map<std::uint64_t, int> edge_ids;
  s.triangles.reserve(mesh.triangles.size());
  for (const Vector3i& tri : mesh.triangles) {
    if ((tri.array() < 0).any() || (tri.array() >= n_vertices).any()) {
      throw Error("mesh triangle refers to vertex " + std::to_string(tri.maxCoeff()) + " of " +
                  std::to_string(n_vertices));
    }
    Triangle t;
    t.a = mesh.vertices[static_cast<std::size_t>(tri[0])];
    t.b = mesh.vertices[static_cast<std::size_t>(tri[1])];
    t.c = mesh.vertices[static_cast<std::size_t>(tri[2])];
    const Vector3f cross = (t.b - t.a).cross(t.c - t.a);
    const float longest = std::max({(t.b - t.a).squaredNorm(), (t.c - t.b).squaredNorm(), (t.a - t.c).squaredNorm()});
    // Zero-area triangles have no normal; their points also lie on neighbouring triangles' edges.
    if (!(cross.norm() > 1e-6f * longest)) continue;
    t.normal = cross.normalized();
    t.lo = t.a.cwiseMin(t.b).cwiseMin(t.c);
    t.hi = t.a.cwiseMax(t.b).cwiseMax(t.c);
    for (int k = 0; k < 3; ++k) {
      t.vertex[static_cast<std::size_t>(k)] = tri[k];
      const int u = tri[k], v = tri[(k + 1) % 3];
      const std::uint64_t key =
          (static_cast<std::uint64_t>(std::min(u, v)) << 32) | static_cast<std::uint32_t>(std::max(u, v));
      const auto [it, inserted] = edge_ids.try_emplace(key, static_cast<int>(s.edge_normal.size()));
      if (inserted) s.edge_normal.push_back(Vector3f::Zero());
      t.edge[static_cast<std::size_t>(k)] = it->second;
      // Both faces of an edge see it under the angle pi: the edge pseudo-normal is the plain sum of face normals.
      s.edge_normal[static_cast<std::size_t>(it->second)] += t.normal;
      const Vector3f& p = mesh.vertices[static_cast<std::size_t>(u)];
      const Vector3f e1 = mesh.vertices[static_cast<std::size_t>(v)] - p;
      const Vector3f e2 = mesh.vertices[static_cast<std::size_t>(tri[(k + 2) % 3])] - p;
      const float angle = std::atan2(e1.cross(e2).norm(), e1.dot(e2));
      s.vertex_normal[static_cast<std::size_t>(u)] += angle * t.normal;
    }
    s.triangles.push_back(t);
  }
  if (s.triangles.empty()) throw Error("mesh has no triangles with a non-zero area");
  return s;
}

// A convex polygon: a triangle clipped by up to four axis-aligned planes has at most seven corners.
struct Polygon {
  std::array<Vector3f, 8> corner;
  int size = 0;
  float min(int axis) const {
    float m = corner[0][axis];
    for (int i = 1; i < size; ++i) m = std::min(m, corner[static_cast<std::size_t>(i)][axis]);
    return m;
  }
  float max(int axis) const {
    float m = corner[0][axis];
    for (int i = 1; i < size; ++i) m = std::max(m, corner[static_cast<std::size_t>(i)][axis]);
    return m;
  }
};

// The part of `p` with lo <= coordinate `axis` <= hi (Sutherland-Hodgman against the slab's two planes).
Polygon clipped(const Polygon& p, int axis, float lo, float hi) {
  auto clip = [axis](const Polygon& in, float bound, float side) {
    Polygon out;
    for (int i = 0; i < in.size; ++i) {
      const Vector3f& a = in.corner[static_cast<std::size_t>(i)];
      const Vector3f& b = in.corner[static_cast<std::size_t>((i + 1) % in.size)];
      const float da = side * (a[axis] - bound), db = side * (b[axis] - bound);
      if (da >= 0.0f) out.corner[static_cast<std::size_t>(out.size++)] = a;
      if ((da < 0.0f) != (db < 0.0f)) out.corner[static_cast<std::size_t>(out.size++)] = a + (b - a) * (da / (da - db));
    }
    return out;
  };
  return clip(clip(p, lo, 1.0f), hi, -1.0f);
}

// Block grid helpers over the map's coarse index.
struct BlockGrid {
  const TsdfMap& map;
  float voxel;

  // The extent of the voxel centres of the blocks with index b along an axis.
  float slab_lo(int b) const { return static_cast<float>(b * TsdfMap::kBlockSize) * voxel; }
  float slab_hi(int b) const { return static_cast<float>(b * TsdfMap::kBlockSize + TsdfMap::kBlockSize - 1) * voxel; }
  // Blocks along `axis` whose voxel centres may come within `radius` of [lo, hi], clipped to the map.
  void block_span(float lo, float hi, float radius, int axis, int& first, int& last) const {
    // The map's box holds every triangle (plus its margin), so these stay within the map's voxel index range.
    const auto v_lo = static_cast<int>(std::floor((lo - radius) / voxel));
    const auto v_hi = static_cast<int>(std::ceil((hi + radius) / voxel));
    first = std::max(TsdfMap::block_of(Vector3i::Constant(v_lo))[0], map.min_block()[axis]);
    last =
        std::min(TsdfMap::block_of(Vector3i::Constant(v_hi))[0], map.min_block()[axis] + map.dims_blocks()[axis] - 1);
  }

  // Centre and half size of the box spanned by the block's voxel centres.
  Vector3f center(const Vector3i& block) const {
    return (block.cast<float>() * TsdfMap::kBlockSize).array() * voxel + 0.5f * (TsdfMap::kBlockSize - 1) * voxel;
  }
  float half() const { return 0.5f * (TsdfMap::kBlockSize - 1) * voxel; }
  // Calls visit(block) for every block of the map whose voxel-centre box may come within `radius` of the triangle:
  // the triangle is clipped to each slab of blocks along x, each piece to each slab along y, and the z extent of
  // what remains gives the blocks. The work is proportional to the blocks near the triangle, not to its bounding
  // box, which for a long sliver across the map is most of the map.
  template <typename Visit>
  void for_each_block_near(const Triangle& t, float radius, Visit&& visit) const {
    // Float clipping may round a point just inside a slab to just outside; the overlap test after it is exact.
    const float r = radius + 0.01f * voxel;
    const Polygon triangle{{t.a, t.b, t.c}, 3};
    int x0, x1;
    block_span(t.lo.x(), t.hi.x(), r, 0, x0, x1);
    for (int x = x0; x <= x1; ++x) {
      const Polygon column = clipped(triangle, 0, slab_lo(x) - r, slab_hi(x) + r);
      if (column.size == 0) continue;
      int y0, y1;
      block_span(column.min(1), column.max(1), r, 1, y0, y1);
      for (int y = y0; y <= y1; ++y) {
        const Polygon piece = clipped(column, 1, slab_lo(y) - r, slab_hi(y) + r);
        if (piece.size == 0) continue;
        int z0, z1;
        block_span(piece.min(2), piece.max(2), r, 2, z0, z1);
        for (int z = z0; z <= z1; ++z) visit(Vector3i(x, y, z));
      }
    }
  }
  Vector3i block_of_cell(std::int64_t cell) const {
    const Vector3i& d = map.dims_blocks();
    const auto x = static_cast<int>(cell % d.x());
    const auto y = static_cast<int>((cell / d.x()) % d.y());
    const auto z = static_cast<int>(cell / (static_cast<std::int64_t>(d.x()) * d.y()));
    return map.min_block() + Vector3i(x, y, z);
  }
};

struct Candidate {
  float lower_bound;
  int triangle;
};

using BlockValues = std::array<std::int16_t, TsdfMap::kVoxelsPerBlock>;

BlockValues signed_distances(const Surface& surface, const std::vector<Candidate>& candidates, const Vector3i& block,
                             const TsdfMap& map) {
  BlockValues out;
  const float trunc = map.truncation();
  const Vector3i first_voxel = block * TsdfMap::kBlockSize;
  for (int l = 0; l < TsdfMap::kVoxelsPerBlock; ++l) {
    const Vector3i local(l % TsdfMap::kBlockSize, (l / TsdfMap::kBlockSize) % TsdfMap::kBlockSize,
                         l / (TsdfMap::kBlockSize * TsdfMap::kBlockSize));
    const Vector3f p = map.center_of(first_voxel + local);
    float best = std::numeric_limits<float>::infinity();  // squared distance
    const Triangle* best_triangle = nullptr;
    Feature best_feature = Feature::kFace;
    Vector3f best_point = Vector3f::Zero();
    for (const Candidate& c : candidates) {
      if (c.lower_bound * c.lower_bound >= best) break;  // sorted: no later candidate can be closer
      const Triangle& t = surface.triangles[static_cast<std::size_t>(c.triangle)];
      if (((t.lo - p).cwiseMax(p - t.hi).cwiseMax(0.0f)).squaredNorm() >= best) continue;
      Feature f;
      const Vector3f q = closest_on_triangle(p, t, f);
      const float d2 = (p - q).squaredNorm();
      if (d2 < best) {
        best = d2;
        best_triangle = &t;
        best_feature = f;
        best_point = q;
      }
    }
    if (!best_triangle) {
      out[static_cast<std::size_t>(l)] = TsdfMap::kUnknownValue;
      continue;
    }
    const float d = std::sqrt(best);
    const bool inside = (p - best_point).dot(surface.pseudo_normal(*best_triangle, best_feature)) < 0.0f;
    out[static_cast<std::size_t>(l)] = map.quantize(std::min(d, trunc) * (inside ? -1.0f : 1.0f));
  }
  return out;
}

// Marks as free every component of non-band blocks whose bordering band voxels are mostly positive.
void fill_free_space(TsdfMap& map, const BlockGrid& grid, const std::vector<int>& band_of_cell,
                     const std::vector<BlockValues>& values) {
  const Vector3i& dims = map.dims_blocks();
  const std::int64_t cells = static_cast<std::int64_t>(band_of_cell.size());
  const std::int64_t stride[3] = {1, dims.x(), static_cast<std::int64_t>(dims.x()) * dims.y()};
  std::vector<char> visited(band_of_cell.size(), 0);
  std::vector<std::int64_t> component;
  for (std::int64_t seed = 0; seed < cells; ++seed) {
    if (visited[static_cast<std::size_t>(seed)] || band_of_cell[static_cast<std::size_t>(seed)] >= 0) continue;
    component.clear();
    component.push_back(seed);
    visited[static_cast<std::size_t>(seed)] = 1;
    std::int64_t positive = 0, negative = 0;
    for (std::size_t next = 0; next < component.size(); ++next) {
      const std::int64_t cell = component[next];
      const Vector3i rel = grid.block_of_cell(cell) - map.min_block();
      for (int axis = 0; axis < 3; ++axis) {
        for (int dir : {-1, 1}) {
          const int r = rel[axis] + dir;
          if (r < 0 || r >= dims[axis]) continue;
          const std::int64_t neighbour = cell + dir * stride[axis];
          const int band = band_of_cell[static_cast<std::size_t>(neighbour)];
          if (band < 0) {
            if (!visited[static_cast<std::size_t>(neighbour)]) {
              visited[static_cast<std::size_t>(neighbour)] = 1;
              component.push_back(neighbour);
            }
            continue;
          }
          // The neighbour's voxel layer that faces this block.
          const BlockValues& v = values[static_cast<std::size_t>(band)];
          for_each_facing_voxel(axis, dir, [&](int li) {
            const std::int16_t q = v[static_cast<std::size_t>(li)];
            if (q == TsdfMap::kUnknownValue) return;
            positive += q > 0;
            negative += q < 0;
          });
        }
      }
    }
    if (positive > negative) {
      for (std::int64_t cell : component) map.mark_block_free(grid.block_of_cell(cell));
    }
  }
}

}  // namespace

TsdfMap build_map_from_mesh(const TriangleMesh& mesh, const MeshMapOptions& options, const ProgressFn& progress) {
  const float vs = options.voxel_size;
  const float trunc = options.truncation;
  if (!(vs > 0.0f) || !std::isfinite(vs)) throw Error("voxel size must be positive, got " + std::to_string(vs));
  if (!(trunc >= vs) || !std::isfinite(trunc)) {
    throw Error("truncation (" + std::to_string(trunc) + " m) must be at least the voxel size (" + std::to_string(vs) +
                " m)");
  }
  if (!(options.margin >= 0.0f) || !std::isfinite(options.margin)) throw Error("margin must not be negative");
  if (mesh.triangles.empty()) throw Error("mesh has no triangles");
  const Surface surface = prepare_surface(mesh);

  // The box holds the whole truncation band, whatever the margin.
  const float border = std::max(options.margin, trunc);
  const Vector3f lo = mesh.min_corner().array() - border, hi = mesh.max_corner().array() + border;
  BuildBudget budget(options.max_memory_bytes);
  // Per cell of the box: the coarse index entry, the band lookup, the free-space search's mark and queue entry.
  budget.charge(TsdfMap::box_cells(vs, trunc, lo, hi) * (2 * sizeof(std::uint32_t) + 1 + sizeof(std::int64_t)),
                "the bounding box in blocks");
  TsdfMap map = TsdfMap::covering(vs, trunc, lo, hi);
  const BlockGrid grid{map, vs};
  const std::size_t cells = map.coarse_index().size();

  // 1. Band blocks. The overlap test grows the box by the truncation in every axis, a superset of the band.
  std::vector<int> band_of_cell(cells, -1);
  std::vector<Vector3i> band_blocks;
  for (const Triangle& t : surface.triangles) {
    grid.for_each_block_near(t, trunc, [&](const Vector3i& block) {
      int& band = band_of_cell[static_cast<std::size_t>(map.coarse_cell(block))];
      if (band >= 0 || !overlaps(t, grid.center(block), grid.half() + trunc)) return;
      // The block's signed distances, its pool block and its place in the lists.
      budget.charge(2 * sizeof(BlockValues) + sizeof(Vector3i) + sizeof(std::vector<Candidate>),
                    "blocks near the surface");
      band = static_cast<int>(band_blocks.size());
      band_blocks.push_back(block);
    });
  }

  // 2. Candidate triangles per band block. A band block has a triangle within sqrt(3)*truncation of its voxel-centre
  //    box, so no voxel of it is farther than `reach` from its closest triangle, and every triangle that close passes
  //    the overlap test with the box grown by `reach`.
  const float reach = std::sqrt(3.0f) * (trunc + 2.0f * grid.half()) + vs;
  std::vector<std::vector<Candidate>> candidates(band_blocks.size());
  for (std::size_t i = 0; i < surface.triangles.size(); ++i) {
    const Triangle& t = surface.triangles[i];
    grid.for_each_block_near(t, reach, [&](const Vector3i& block) {
      const int band = band_of_cell[static_cast<std::size_t>(map.coarse_cell(block))];
      if (band < 0 || !overlaps(t, grid.center(block), grid.half() + reach)) return;
      budget.charge(sizeof(Candidate), "triangles near each block");
      candidates[static_cast<std::size_t>(band)].push_back(
          {distance_lower_bound(t, grid.center(block), grid.half()), static_cast<int>(i)});
    });
  }

  // 3. Signed distances, block-parallel (blocks are independent). Progress is reported between batches, from one
  //    thread.
  std::vector<BlockValues> values(band_blocks.size());
  const auto total = static_cast<std::int64_t>(band_blocks.size());
  const std::int64_t batch = std::max<std::int64_t>(256, total / 100);
  for (std::int64_t begin = 0; begin < total; begin += batch) {
    const std::int64_t end = std::min(total, begin + batch);
#pragma omp parallel for schedule(dynamic, 8)
    for (std::int64_t b = begin; b < end; ++b) {
      auto& list = candidates[static_cast<std::size_t>(b)];
      std::sort(list.begin(), list.end(),
                [](const Candidate& l, const Candidate& r) { return l.lower_bound < r.lower_bound; });
      values[static_cast<std::size_t>(b)] =
          signed_distances(surface, list, band_blocks[static_cast<std::size_t>(b)], map);
      std::vector<Candidate>().swap(list);
    }
    if (progress) progress(static_cast<std::size_t>(end), static_cast<std::size_t>(total));
  }
  for (std::size_t b = 0; b < band_blocks.size(); ++b) map.set_block(band_blocks[b], values[b]);

  if (options.fill_free_space) fill_free_space(map, grid, band_of_cell, values);
  map.compact();
  return map;
}

}  // namespace tsdf_mcl
