#pragma once
// The pose estimate from a weighted particle set: the weighted mean of the dominant mode, not of the whole
// cloud. While the belief is multimodal (symmetric rooms, early global localization) the mean of all
// particles lies between the modes, in a place no particle supports.
//
// Modes are connected components of occupied cells of a grid over (x, y, z, yaw) (cells sharing a face, yaw
// wrapping around); the component with the largest total weight wins. Its
// rotation mean is the eigenvector of the largest eigenvalue of Σ w q qᵀ (Markley et al. 2007), which needs
// no sign alignment and is exact for the chordal distance.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "tsdf_mcl/pose.hpp"
#include "tsdf_mcl/sensor_evaluator.hpp"

namespace tsdf_mcl {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

struct PoseEstimateOptions {
  bool best_particle = false;  // report the highest-weight particle instead of the mode's mean
  float cluster_bin_xyz = 0.5f;  // m: grid cell for mode finding
  float cluster_bin_yaw = 0.5235988f;  // rad (30°)
  // Converged: the dominant mode holds at least this share of the weight and its standard deviations (the
  // square root of the largest eigenvalue of the position and of the rotation covariance) stay below these.
  double converged_weight = 0.8;
  double converged_std_xyz = 0.25;  // m
  double converged_std_angle = 0.0872665;  // rad (5°)

  void validate() const;  // throws Error naming the parameter
};

struct PoseEstimate {
  Pose pose = Pose::Identity();
  // Covariance of (x, y, z, rx, ry, rz): position in the world frame, rotation as the rotation vector of
  // mean⁻¹ · R (tangent space at the mean, body frame). Weighted over the dominant mode's particles.
  Matrix6d covariance = Matrix6d::Zero();
  double mode_weight = 0.0;      // share of the total weight in the dominant mode
  std::size_t mode_particles = 0;
  std::size_t modes = 0;         // connected components found
  double std_position = 0.0;     // m, sqrt of the largest position-covariance eigenvalue
  double std_rotation = 0.0;     // rad, likewise for rotation
  // The mode is concentrated (PoseEstimateOptions) and, in ParticleFilter, recovery does not consider the
  // track lost.
  bool converged = false;
};

// Weighted rotation mean (Markley); weights need not be normalized. Throws Error for an empty or zero-weight set.
Eigen::Quaterniond average_rotation(const std::vector<Eigen::Quaterniond>& rotations, const std::vector<double>& weights);

// Keeps its grid, union-find and label buffers between calls.
class PoseEstimator {
 public:
  explicit PoseEstimator(const PoseEstimateOptions& options);

  // Particles 0..n-1 with weights w (any positive scale). Particles with weight below 1e-9 of the largest take
  // no part in mode finding (they cannot change it, and during global localization they are most of the set).
  PoseEstimate estimate(const ParticleArrays& particles, const double* weights, std::size_t n);
  const PoseEstimateOptions& options() const { return options_; }

 private:
  std::uint32_t find(std::uint32_t a);
  PoseEstimateOptions options_;
  std::vector<std::uint64_t> keys_;       // hash table of cells, 0 = empty
  std::vector<std::uint32_t> slot_cell_;
  std::vector<Eigen::Vector4i> cells_;    // cell coordinates
  std::vector<std::uint32_t> parent_;     // union-find over cells
  std::vector<double> cell_weight_;
  std::vector<double> root_weight_;
  std::vector<std::uint32_t> particle_cell_;
  int yaw_cells_ = 12;
};

}  // namespace tsdf_mcl
