#pragma once
// Scan preprocessing before the sensor update: range limits, voxel thinning and a cap on the point count.
//
// The sensor update costs particles x points, so the cap (max_beams) sets its price. Points are not
// picked at random from the raw scan: a LiDAR scan is dense near the sensor and sparse far away, and the far
// walls carry most of the position information. Thinning to one point per voxel first evens the density out;
// the cap then takes every k-th voxel along a Morton (Z-order) curve, which keeps the chosen points spread
// over the whole scan rather than clustered where the curve happens to start.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace tsdf_mcl {

struct ScanPreprocessing {
  float laser_min_range = 1.0f;   // m; closer points (the robot, the operator) are dropped
  float laser_max_range = 60.0f;  // m
  float voxel_size = 0.2f;        // m, thinning grid; 0 keeps every point
  std::size_t max_beams = 512;    // cap on the points used per scan
  std::uint64_t seed = 0;         // the cap's offset along the curve derives from (seed, scan id)

  void validate() const;  // throws Error naming the parameter
};

struct PreprocessingStats {
  std::size_t input = 0;
  std::size_t in_range = 0;
  std::size_t thinned = 0;  // after voxel thinning
  std::size_t output = 0;
};

// Keeps its work buffers between scans, so steady-state processing does not allocate.
class ScanPreprocessor {
 public:
  explicit ScanPreprocessor(const ScanPreprocessing& options);

  // The selected points (sensor frame), valid until the next call. Deterministic for (options, scan_id, points).
  const std::vector<Eigen::Vector3f>& process(const std::vector<Eigen::Vector3f>& points, std::uint64_t scan_id,
                                              PreprocessingStats* stats = nullptr);
  const ScanPreprocessing& options() const { return options_; }

 private:
  ScanPreprocessing options_;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed_;  // (Morton key, point index)
  std::vector<Eigen::Vector3f> out_;
};

}  // namespace tsdf_mcl
