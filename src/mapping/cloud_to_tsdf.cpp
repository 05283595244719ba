// Point cloud -> TSDF.
//
//  1. Working points: the cloud streams through a voxel hash at the map's voxel size; each occupied voxel keeps the
//     average of its points (one working point per voxel: duplicates and dense overlaps of SLAM maps cost nothing).
//     Voxels with fewer than 3 occupied voxels within 2 voxels are dropped as outliers.
//  2. Normals: PCA over the working points within 2 voxels, then again over those of them within 1.5 voxels of the
//     first plane (the same sheet): the other face of a thin wall drops out, the two sheets of a drifted double wall
//     a few cm apart merge, and the point moves onto the sheet's mean plane. Points without a clear plane (poles,
//     edges of thin things, clutter) keep no normal.
//  3. Orientation. With a trajectory: each point's nearest trajectory positions are tried in turn; a position sees the
//     point if the sight line crosses no occupied voxel off the point's own sheet; the normal faces the positions that
//     see it. Without one: rays from the point to both sides of its plane; the side whose rays reach other surfaces
//     is open, the side whose rays hit a parallel sheet within kNearHit (the other face of a wall or slab) is closed.
//     Points still undecided take the orientation of oriented neighbours on the same sheet, most confident first (a
//     minimum-spanning-tree style propagation). Points seen from both sides are two-sided.
//  4. Distances: a brushfire from the working points gives every voxel within the truncation its nearest point; the
//     value is the distance to that point's tangent plane (growing into the Euclidean distance beside the point's
//     footprint), signed by its normal. Where that sign is not known -- beside the edge of a surface, near two-sided
//     sheets and points without a normal -- oriented points around that agree decide it; else only the distance is
//     known: such voxels become positive where free space reaches them, else unknown (a voxel within half a voxel of
//     its point stays positive: it marks the surface). The rest of the blocks reached get +-truncation.
//  5. Free space: carved along the sight lines (trajectory positions -> point, or point -> the surface it sees), block
//     by block away from surfaces and voxel by voxel in blocks near them, as the scan integrator does (and more than
//     two voxels behind a surface where several lines cross: the far side of something thin); then unknown
//     regions that are enclosed (not touching the box's border) and mostly face free space or positive surfaces
//     become free, as the mesh builder does.
#include "cloud_builder.hpp"

namespace tsdf_mcl {
namespace cloud_build {

void Builder::downsample(PointSource& source) {
  VoxelHash hash(budget_);
  std::vector<Vector3f> chunk;
  const double inv = 1.0 / static_cast<double>(vs_);
  const std::uint64_t total = source.size_hint();
  while (source.next(chunk, std::size_t{1} << 20)) {
    for (const Vector3f& p : chunk) {
      ++report_.input_points;
      if (!p.allFinite()) {
        ++report_.non_finite;
        continue;
      }
      Vector3i v;
      bool inside = true;
      for (int a = 0; a < 3; ++a) {
        const double g = std::floor(static_cast<double>(p[a]) * inv + 0.5);
        inside = inside && std::abs(g) <= kMaxPointVoxel;
        v[a] = inside ? static_cast<int>(g) : 0;
      }
      if (!inside) {
        ++report_.out_of_range;
        continue;
      }
      hash.add(v, p - v.cast<float>() * vs_);
    }
    if (total > 0) progress_(0, static_cast<double>(report_.input_points) / static_cast<double>(total));
  }
  if (hash.size() == 0) {
    throw Error("the cloud has no usable point (" + std::to_string(report_.input_points) + " read, " +
                std::to_string(report_.non_finite) + " not finite, " + std::to_string(report_.out_of_range) +
                " farther than " + std::to_string(static_cast<double>(kMaxPointVoxel) * vs_ / 1000.0) +
                " km from the origin)");
  }
  // Sorted by block, then local index: the grid's layout.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> order;
  budget_.charge(hash.size() * (sizeof(order[0]) + 2 * sizeof(Vector3f) + sizeof(Vector3i) + 48), "the working points");
  order.reserve(hash.size());
  const auto& entries = hash.entries();
  for (std::size_t i = 0; i < entries.size(); ++i) {
    if (entries[i].count == 0) continue;
    const Vector3i& v = entries[i].voxel;
    order.emplace_back((block_key(block_of(v)) << 9) | static_cast<std::uint64_t>(local_of(v)),
                       static_cast<std::uint32_t>(i));
  }
  std::sort(order.begin(), order.end());
  w_.voxel.reserve(order.size());
  w_.anchor.reserve(order.size());
  w_.count.reserve(order.size());
  for (const auto& [key, i] : order) {
    const VoxelHash::Entry& e = entries[i];
    w_.voxel.push_back(e.voxel);
    w_.anchor.push_back(e.voxel.cast<float>() * vs_ + e.sum / static_cast<float>(e.count));
    w_.count.push_back(e.count);
  }
  grid_.build(w_.voxel);
}

void Builder::drop_isolated() {
  const std::size_t n = w_.size();
  std::vector<std::uint8_t> keep(n, 0);
  const auto& blocks = grid_.blocks();
  parallel_blocks(blocks.size(), [&](std::size_t k) {
    const Neighbourhood nb(grid_, blocks[k].block);
    const std::uint32_t end = k + 1 < blocks.size() ? blocks[k + 1].first : static_cast<std::uint32_t>(n);
    for (std::uint32_t i = blocks[k].first; i < end; ++i) {
      int neighbours = 0;
      for_each_neighbour(nb, w_.voxel[i], i, [&](std::uint32_t) { ++neighbours; });
      keep[i] = neighbours >= kMinNeighbours;
    }
  });
  std::size_t out = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!keep[i]) {
      ++report_.isolated_voxels;
      report_.isolated_points += w_.count[i];
      continue;
    }
    w_.voxel[out] = w_.voxel[i];
    w_.anchor[out] = w_.anchor[i];
    w_.count[out] = w_.count[i];
    ++out;
  }
  if (out == 0) {
    throw Error("every one of the cloud's " + std::to_string(n) + " occupied voxels is isolated (fewer than " +
                std::to_string(kMinNeighbours) + " occupied voxels within " + std::to_string(kRadius) +
                " voxels): the cloud is too sparse for " + std::to_string(vs_) + " m voxels");
  }
  w_.voxel.resize(out);
  w_.anchor.resize(out);
  w_.count.resize(out);
  report_.voxels = out;
  report_.used_points = report_.input_points - report_.non_finite - report_.out_of_range - report_.isolated_points;
  grid_.build(w_.voxel);
  budget_.charge(grid_.bytes(), "the occupied blocks");
  progress_(1, 0.1);
}

}  // namespace cloud_build

using cloud_build::Builder;
using cloud_build::validate;

std::string describe(const CloudMapReport& r) {
  const auto percent = [](std::uint64_t part, std::uint64_t whole) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.1f %%",
                  whole ? 100.0 * static_cast<double>(part) / static_cast<double>(whole) : 0.0);
    return std::string(buf);
  };
  const auto n = [](std::uint64_t v) { return std::to_string(v); };
  std::string out = "build-map: cloud: " + n(r.input_points) + " points read; dropped " + n(r.non_finite) +
                    " not finite, " + n(r.out_of_range) + " out of range, " + n(r.isolated_points) + " isolated (" +
                    n(r.isolated_voxels) + " voxels); " + n(r.used_points) + " used, in " + n(r.voxels) + " voxels\n";
  out += "build-map: normals: " + n(r.planar) + " of the voxels planar, oriented " + n(r.oriented_by_trajectory) +
         " by the trajectory, " + n(r.oriented_by_visibility) + " by visibility, " + n(r.oriented_by_propagation) +
         " by propagation; " + n(r.two_sided) + " two-sided; " + n(r.unsigned_points) + " unsigned (distance only)\n";
  out += "build-map: surface: " + n(r.surface_points) + " of the used points (" +
         percent(r.surface_points, r.used_points) + ") within a voxel of the map's surface; " + n(r.band_blocks) +
         " blocks near it, " + n(r.free_blocks) + " free blocks from " + n(r.sight_lines) + " sight lines\n";
  char times[256];
  std::snprintf(times, sizeof(times),
                "build-map: seconds: %.1f reading and averaging, %.1f normals, %.1f orientation, %.1f distances, "
                "%.1f free space; %.1f in all\n",
                r.read_seconds, r.normal_seconds, r.orient_seconds, r.distance_seconds, r.free_seconds, r.seconds);
  return out + times;
}

TsdfMap build_map_from_cloud(PointSource& source, const CloudMapOptions& options, const ProgressFn& progress,
                             CloudMapReport* report) {
  validate(options);
  const auto started = std::chrono::steady_clock::now();
  CloudMapReport local;
  CloudMapReport& r = report ? *report : local;
  r = CloudMapReport{};
  Builder builder(options, progress, r);
  TsdfMap map = builder.run(source);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return map;
}

TsdfMap build_map_from_cloud(const std::vector<Eigen::Vector3f>& points, const CloudMapOptions& options,
                             const ProgressFn& progress, CloudMapReport* report) {
  VectorPointSource source(points);
  return build_map_from_cloud(source, options, progress, report);
}

}  // namespace tsdf_mcl
