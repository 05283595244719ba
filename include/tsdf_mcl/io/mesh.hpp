#pragma once
#include <Eigen/Core>
#include <filesystem>
#include <vector>

namespace tsdf_mcl {

// An indexed triangle mesh; triangle winding is counter-clockwise seen from the side the normal points to.
struct TriangleMesh {
  std::vector<Eigen::Vector3f> vertices;
  std::vector<Eigen::Vector3i> triangles;

  void append(const TriangleMesh& other);
  Eigen::Vector3f min_corner() const;
  Eigen::Vector3f max_corner() const;
};

// STL (binary and ASCII), PLY (ascii, binary little/big endian), OBJ; chosen by extension.
TriangleMesh load_mesh(const std::filesystem::path& file);
void save_mesh_ply(const TriangleMesh& mesh, const std::filesystem::path& file);

}  // namespace tsdf_mcl
