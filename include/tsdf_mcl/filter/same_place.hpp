#pragma once
// When two poses are one place: within a distance and an angle of each other. The filter's one such test (the
// persistence of a place, a track's continuation, a rival found again, which place the estimate reports).
#include "tsdf_mcl/core/pose.hpp"

namespace tsdf_mcl {

struct SamePlace {
  double max_m = 0.5;     // converged_max_jump
  double max_rad = 0.35;  // rad

  bool operator()(const Pose& a, const Pose& b) const {
    return (a.translation() - b.translation()).norm() <= max_m &&
           rotation_angle_between(a.linear(), b.linear()) <= max_rad;
  }
  void validate() const;  // throws Error naming the parameter
};

}  // namespace tsdf_mcl
