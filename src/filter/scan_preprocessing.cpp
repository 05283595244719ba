#include "tsdf_mcl/filter/scan_preprocessing.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/morton.hpp"
#include "tsdf_mcl/core/random.hpp"

namespace tsdf_mcl {

void ScanPreprocessing::validate() const {
  if (!(laser_min_range >= 0.0f) || !std::isfinite(laser_min_range)) {
    throw Error("laser_min_range must be a non-negative number");
  }
  if (!(laser_max_range > laser_min_range) || !std::isfinite(laser_max_range)) {
    throw Error("laser_max_range must be larger than laser_min_range");
  }
  if (!(voxel_size >= 0.0f) || !std::isfinite(voxel_size)) throw Error("scan voxel size must not be negative");
  if (max_beams == 0) throw Error("max_beams must be at least 1");
}

ScanPreprocessor::ScanPreprocessor(const ScanPreprocessing& options) : options_(options) { options_.validate(); }

const std::vector<Eigen::Vector3f>& ScanPreprocessor::process(const std::vector<Eigen::Vector3f>& points,
                                                              std::uint64_t scan_id, PreprocessingStats* stats) {
  const float min2 = options_.laser_min_range * options_.laser_min_range;
  const float max2 = options_.laser_max_range * options_.laser_max_range;
  const bool thin = options_.voxel_size > 0.0f;
  const float inv_voxel = thin ? 1.0f / options_.voxel_size : 0.0f;

  keyed_.clear();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3f& p = points[i];
    if (!p.allFinite()) throw Error("scan point " + std::to_string(i) + " is not finite");
    const float r2 = p.squaredNorm();
    if (r2 < min2 || r2 > max2) continue;
    keyed_.emplace_back(thin ? morton_code(p, inv_voxel) : 0u, static_cast<std::uint32_t>(i));
  }
  const std::size_t in_range = keyed_.size();
  if (thin) {
    // Sorting by (key, index) makes the kept point of each voxel its first one in scan order.
    std::sort(keyed_.begin(), keyed_.end());
    keyed_.erase(
        std::unique(keyed_.begin(), keyed_.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
        keyed_.end());
  }
  const std::size_t thinned = keyed_.size();

  out_.clear();
  if (thinned <= options_.max_beams) {
    for (const auto& k : keyed_) out_.push_back(points[k.second]);
  } else {
    // Systematic selection: one point per stratum of thinned / max_beams consecutive voxels along the curve.
    Rng rng(options_.seed, 0x5CA9ull, scan_id);
    const double stride = static_cast<double>(thinned) / static_cast<double>(options_.max_beams);
    const double offset = rng.uniform() * stride;
    for (std::size_t k = 0; k < options_.max_beams; ++k) {
      const auto idx = std::min(thinned - 1, static_cast<std::size_t>(offset + stride * static_cast<double>(k)));
      out_.push_back(points[keyed_[idx].second]);
    }
  }
  if (stats) {
    stats->input = points.size();
    stats->in_range = in_range;
    stats->thinned = thinned;
    stats->output = out_.size();
  }
  return out_;
}

}  // namespace tsdf_mcl
