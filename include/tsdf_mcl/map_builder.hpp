#pragma once
// Building TSDF maps: from triangle meshes and from registered scans.
#include <functional>

#include "tsdf_mcl/dataset.hpp"
#include "tsdf_mcl/mesh.hpp"
#include "tsdf_mcl/tsdf_map.hpp"

namespace tsdf_mcl {

// Called with (done, total) while long work runs.
using ProgressFn = std::function<void(std::size_t done, std::size_t total)>;

struct MeshMapOptions {
  float voxel_size = kDefaultVoxelSize;
  float truncation = kDefaultTruncation;
  float margin = 1.0f;           // space added around the mesh's bounding box (m; at least the truncation is added)
  bool fill_free_space = true;   // blocks beyond the band on the normals' positive side become free blocks
};
// Signed distance within the truncation band; the sign comes from the surface normals (the angle-weighted
// pseudo-normal of the closest feature), so meshes need not be watertight. Every voxel of a block near the surface
// gets its exact signed distance, clamped to the truncation. With fill_free_space, each connected region of the
// remaining blocks becomes free space if most band voxels bordering it are positive, else stays unknown (the
// inside of closed solids). Progress counts the blocks near the surface.
TsdfMap build_map_from_mesh(const TriangleMesh& mesh, const MeshMapOptions& options,
                            const ProgressFn& progress = {});

struct ScanMapOptions {
  float voxel_size = kDefaultVoxelSize;
  float truncation = kDefaultTruncation;
  float min_range = 0.3f;
  float max_range = 60.0f;
  float margin = 1.0f;
};
// TSDF integration of registered scans (the dataset's poses) with weighted running averages of the projective
// distance; free space is carved along each ray up to the truncation band, voxel by voxel in blocks near surfaces
// and block by block elsewhere; what no ray reached stays unknown. The map covers the observed box plus the
// margin. Progress counts three passes over the scans (bounds, band, free space). The result does not depend on
// the number of OpenMP threads.
TsdfMap build_map_from_scans(const Dataset& dataset, const std::vector<std::size_t>& scans,
                             const ScanMapOptions& options, const ProgressFn& progress = {});

}  // namespace tsdf_mcl
