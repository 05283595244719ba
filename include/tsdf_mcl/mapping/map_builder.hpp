#pragma once
// Building TSDF maps: from triangle meshes, from registered scans and from point clouds.
#include <functional>
#include <string>

#include "tsdf_mcl/io/cloud_io.hpp"
#include "tsdf_mcl/io/dataset.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/io/mesh.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

// Called with (done, total) while long work runs.
using ProgressFn = std::function<void(std::size_t done, std::size_t total)>;

struct MeshMapOptions {
  float voxel_size = kDefaultVoxelSize;
  float truncation = kDefaultTruncation;
  float margin = 1.0f;          // space added around the mesh's bounding box (m; at least the truncation is added)
  bool fill_free_space = true;  // blocks beyond the band on the normals' positive side become free blocks
  // Working memory (map and builder buffers); past it building stops with an Error naming the budget.
  std::uint64_t max_memory_bytes = std::uint64_t{limits::kDefaultBuildMemoryMiB} << 20;
};
// Signed distance within the truncation band; the sign comes from the surface normals (the angle-weighted
// pseudo-normal of the closest feature), so meshes need not be watertight. Every voxel of a block near the surface
// gets its exact signed distance, clamped to the truncation. With fill_free_space, each connected region of the
// remaining blocks becomes free space if most band voxels bordering it are positive, else stays unknown (the
// inside of closed solids). Progress counts the blocks near the surface.
TsdfMap build_map_from_mesh(const TriangleMesh& mesh, const MeshMapOptions& options, const ProgressFn& progress = {});

struct ScanMapOptions {
  float voxel_size = kDefaultVoxelSize;
  float truncation = kDefaultTruncation;
  float min_range = 0.3f;
  float max_range = 60.0f;
  float margin = 1.0f;
  std::uint64_t max_memory_bytes = std::uint64_t{limits::kDefaultBuildMemoryMiB} << 20;  // as for meshes
};
// TSDF integration of registered scans (the dataset's poses) with weighted running averages of the projective
// distance; free space is carved along each ray up to the truncation band, voxel by voxel in blocks near surfaces
// and block by block elsewhere; what no ray reached stays unknown. The map covers the observed box plus the
// margin. Progress counts three passes over the scans (bounds, band, free space). The result does not depend on
// the number of OpenMP threads.
TsdfMap build_map_from_scans(const Dataset& dataset, const std::vector<std::size_t>& scans,
                             const ScanMapOptions& options, const ProgressFn& progress = {});

struct CloudMapOptions {
  float voxel_size = kDefaultVoxelSize;
  float truncation = kDefaultTruncation;
  float margin = 1.0f;  // space added around the cloud's bounding box (m)
  // Sensor positions of the mapping run, world frame (a SLAM trajectory, a dataset's poses); empty if not known.
  // With them, each point's normal faces a position that sees it and free space is carved along the sight lines;
  // without, orientation and free space come from what the surfaces of the cloud see of each other.
  std::vector<Eigen::Vector3f> trajectory;
  float max_range = 60.0f;  // a trajectory position sees points at most this far
  // Unknown space enclosed by free space and surfaces facing it (not touching the box's border) becomes free too.
  bool fill_free_space = true;
  std::uint64_t max_memory_bytes = std::uint64_t{limits::kDefaultBuildMemoryMiB} << 20;  // as for meshes
};

// What became of the cloud's points (build-map prints it).
struct CloudMapReport {
  std::uint64_t input_points = 0;  // read from the source
  std::uint64_t non_finite = 0;    // NaN/Inf coordinates: dropped
  std::uint64_t out_of_range = 0;  // beyond +-2^23 voxels from the origin: dropped
  std::uint64_t isolated_points =
      0;                             // in voxels with fewer than 3 occupied voxels within 2 voxels: dropped as outliers
  std::uint64_t used_points = 0;     // the rest, averaged into one working point per voxel
  std::uint64_t surface_points = 0;  // used points whose voxel's point lies within a voxel of the map's zero crossing
  std::size_t voxels = 0;            // working points kept (occupied voxels)
  std::size_t isolated_voxels = 0;
  std::size_t planar = 0;                   // working points with a surface normal (the rest: edges, poles, clutter)
  std::size_t oriented_by_trajectory = 0;   // normal faces a trajectory position that sees the point
  std::size_t oriented_by_visibility = 0;   // no trajectory: the side that sees other surfaces
  std::size_t oriented_by_propagation = 0;  // from oriented neighbours on the same surface
  std::size_t two_sided = 0;                // seen from both sides (a sheet thinner than the voxels can resolve)
  std::size_t unsigned_points = 0;  // no normal, two-sided or no orientation: distance only, signed by free space
  std::size_t sight_lines = 0;      // segments along which free space was carved
  std::size_t band_blocks = 0, free_blocks = 0;
  // Wall-clock seconds of the stages: reading and averaging, normals, orientation, distances, free space, in all.
  double read_seconds = 0.0, normal_seconds = 0.0, orient_seconds = 0.0, distance_seconds = 0.0, free_seconds = 0.0;
  double seconds = 0.0;
};

// The report in four lines, as build-map prints it ("build-map: ..." each).
std::string describe(const CloudMapReport& report);

// Point cloud -> TSDF: the points are averaged into one point per voxel, isolated voxels dropped, normals fitted
// by PCA over the voxels within two voxels and oriented (see CloudMapOptions::trajectory); voxels within the
// truncation of the points get the signed distance to the tangent plane of their nearest point (the distance alone,
// signed by free space, where the side is not known); free space is carved along sight lines. Same block layout,
// truncation and free-block conventions as the other builders; stops with an Error past the memory budget.
// Progress runs over the stages. The result does not depend on the number of OpenMP threads.
TsdfMap build_map_from_cloud(PointSource& source, const CloudMapOptions& options, const ProgressFn& progress = {},
                             CloudMapReport* report = nullptr);
TsdfMap build_map_from_cloud(const std::vector<Eigen::Vector3f>& points, const CloudMapOptions& options,
                             const ProgressFn& progress = {}, CloudMapReport* report = nullptr);

}  // namespace tsdf_mcl
