#include "shapes.hpp"

#include <cassert>

namespace tsdf_mcl::sim {

namespace {

int add_vertex(TriangleMesh& mesh, float x, float y, float z) {
  mesh.vertices.emplace_back(x, y, z);
  return static_cast<int>(mesh.vertices.size()) - 1;
}

// Quad a-b-c-d, counter-clockwise seen from the side its normal points to.
void add_quad(TriangleMesh& mesh, int a, int b, int c, int d) {
  mesh.triangles.emplace_back(a, b, c);
  mesh.triangles.emplace_back(a, c, d);
}

}  // namespace

void add_box(TriangleMesh& mesh, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  assert((lo.array() < hi.array()).all());
  // Corner i has x = hi.x if bit 0 is set, y = hi.y if bit 1, z = hi.z if bit 2.
  int v[8];
  for (int i = 0; i < 8; ++i) {
    v[i] = add_vertex(mesh, (i & 1) ? hi.x() : lo.x(), (i & 2) ? hi.y() : lo.y(), (i & 4) ? hi.z() : lo.z());
  }
  add_quad(mesh, v[0], v[4], v[6], v[2]);  // -x
  add_quad(mesh, v[1], v[3], v[7], v[5]);  // +x
  add_quad(mesh, v[0], v[1], v[5], v[4]);  // -y
  add_quad(mesh, v[2], v[6], v[7], v[3]);  // +y
  add_quad(mesh, v[0], v[2], v[3], v[1]);  // -z
  add_quad(mesh, v[4], v[5], v[7], v[6]);  // +z
}

void add_prism_xz(TriangleMesh& mesh, const std::vector<Eigen::Vector2f>& profile, float y0, float y1) {
  assert(profile.size() >= 3 && y0 < y1);
  const int n = static_cast<int>(profile.size());
  const int first = static_cast<int>(mesh.vertices.size());
  for (const auto& p : profile) add_vertex(mesh, p.x(), y0, p.y());
  for (const auto& p : profile) add_vertex(mesh, p.x(), y1, p.y());
  // The y0 cap faces -y, where the profile reads counter-clockwise; the y1 cap is its mirror.
  for (int i = 1; i + 1 < n; ++i) {
    mesh.triangles.emplace_back(first, first + i, first + i + 1);
    mesh.triangles.emplace_back(first + n, first + n + i + 1, first + n + i);
  }
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    add_quad(mesh, first + i, first + n + i, first + n + j, first + j);
  }
}

}  // namespace tsdf_mcl::sim
