#include <algorithm>
#include <cmath>
#include <cstdio>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/mapping/map_builder.hpp"

namespace tsdf_mcl {
namespace {

std::string format(const char* f, double a, double b = 0.0) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), f, a, b);
  return buf;
}

}  // namespace

void check_build_geometry(double voxel, double truncation, double margin, const BuildGeometryNames& names) {
  if (!(voxel >= kMinBuildVoxel && voxel <= kMaxBuildVoxel)) {
    throw Error(names.voxel + " must be in " + format("%g..%g m", kMinBuildVoxel, kMaxBuildVoxel) + ", got " +
                format("%g", voxel));
  }
  const double max_truncation = std::min(kMaxTruncationVoxels * voxel, kMaxTruncation);
  if (!(truncation >= voxel && truncation <= max_truncation)) {
    throw Error(names.truncation + " must be in " + format("%g..%g m", voxel, max_truncation) +
                " (at least the voxel, at most " + format("%g", kMaxTruncationVoxels) + " voxels and " +
                format("%g m", kMaxTruncation) + "), got " + format("%g m", truncation));
  }
  if (!(margin >= 0.0) || !std::isfinite(margin)) throw Error(names.margin + " must not be negative");
}

}  // namespace tsdf_mcl
