#pragma once
// Stamped poses parent_T_child from one topic (nav_msgs/Odometry, geometry_msgs/PoseStamped or
// PoseWithCovarianceStamped), interpolated as tf is (linear, slerp), never extrapolated.
#include <algorithm>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/io/transform_tree.hpp"

namespace tsdf_mcl::bag_io {

struct PoseSeries {
  std::string topic, parent, child;
  std::vector<std::pair<double, Pose>> samples;

  // By time; of equal stamps the later message stands.
  void sort() {
    std::stable_sort(samples.begin(), samples.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<std::pair<double, Pose>> unique;
    for (const auto& s : samples) {
      if (!unique.empty() && unique.back().first == s.first)
        unique.back() = s;
      else
        unique.push_back(s);
    }
    samples = std::move(unique);
  }
  Pose at(double t) const {
    auto hi = std::lower_bound(samples.begin(), samples.end(), t, [](const auto& s, double v) { return s.first < v; });
    if (hi == samples.end()) return samples.back().second;
    if (hi == samples.begin() || hi->first - t <= 1e-9) return hi->second;
    const auto lo = std::prev(hi);
    if (t - lo->first <= 1e-9) return lo->second;
    return interpolate_pose(lo->second, hi->second, (t - lo->first) / (hi->first - lo->first));
  }
};

}  // namespace tsdf_mcl::bag_io
