#pragma once
#include <Eigen/Core>
#include <vector>

namespace tsdf_mcl {

// Points of one scan in the sensor frame.
struct PointCloud {
  std::vector<Eigen::Vector3f> points;
  std::vector<float> intensity;  // empty or one per point

  std::size_t size() const { return points.size(); }
  bool empty() const { return points.empty(); }
};

}  // namespace tsdf_mcl
