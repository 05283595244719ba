#pragma once
// Closed solids appended to a triangle mesh, counter-clockwise seen from outside (normals point out).
#include <Eigen/Core>
#include <vector>

#include "tsdf_mcl/io/mesh.hpp"

namespace tsdf_mcl::sim {

// Axis-aligned box [lo, hi].
void add_box(TriangleMesh& mesh, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi);

// A convex polygon in the x-z plane (counter-clockwise with x to the right and z up), extruded along y
// from y0 to y1: ramps and wedges.
void add_prism_xz(TriangleMesh& mesh, const std::vector<Eigen::Vector2f>& profile_xz, float y0, float y1);

}  // namespace tsdf_mcl::sim
