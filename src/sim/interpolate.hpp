#pragma once
#include "tsdf_mcl/core/pose.hpp"

namespace tsdf_mcl::sim {

// The pose a fraction f of the way from a to b: slerp for the rotation, linear for the translation.
inline Pose interpolate(const Pose& a, const Pose& b, double f) {
  Pose out = Pose::Identity();
  out.linear() = Eigen::Quaterniond(a.linear()).slerp(f, Eigen::Quaterniond(b.linear())).toRotationMatrix();
  out.translation() = (1.0 - f) * a.translation() + f * b.translation();
  return out;
}

}  // namespace tsdf_mcl::sim
