#pragma once
// The pose estimate from a weighted particle set: the weighted mean of the dominant mode, not of the whole
// cloud. While the belief is multimodal (symmetric rooms, early global localization) the mean of all
// particles lies between the modes, in a place no particle supports.
//
// Modes are connected components of occupied cells of a grid over (x, y, z, yaw) (cells sharing a face, yaw
// wrapping around), separately for each sensor axis that may point up (a global search without a known
// gravity holds upside-down and sideways places too); the component with the largest total weight wins. Its
// rotation mean is the eigenvector of the largest eigenvalue of Σ w q qᵀ (Markley et al. 2007), which needs
// no sign alignment and is exact for the chordal distance.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

struct PoseEstimateOptions {
  bool best_particle = false;          // report the highest-weight particle instead of the mode's mean
  float cluster_bin_xyz = 0.5f;        // m: grid cell for mode finding
  float cluster_bin_yaw = 0.5235988f;  // rad (30°)
  // Converged: the dominant mode holds at least this share of the weight and its standard deviations (the
  // square root of the largest eigenvalue of the position and of the rotation covariance) stay below these.
  double converged_weight = 0.8;
  double converged_std_xyz = 0.25;         // m
  double converged_std_angle = 0.0872665;  // rad (5°)
  std::size_t max_places = 8;              // modes described in PoseEstimate::places (the heaviest)
  // Particles lighter than this share of the heaviest take no part in mode finding (during global localization
  // most of the set). Low, so that a faint place (a look-alike the challengers just found) is a mode.
  double min_relative_weight = 1e-30;

  void validate() const;  // throws Error naming the parameter
};

// The share of the whole scan a place explains: its inlier ratio (over the points with map evidence) times its map
// coverage. A place whose points fly out of the map does not explain them. NaN coverage (not computed): the inlier
// ratio alone.
inline double explained_share(double inlier_ratio, double coverage) {
  return std::isnan(coverage) ? inlier_ratio : inlier_ratio * coverage;
}

// One mode of the belief: a place (and orientation) the particles say the sensor may be.
struct Place {
  Pose pose = Pose::Identity();  // weighted mean of the mode's particles (ParticleFilter: refined onto the map)
  Matrix6d covariance = Matrix6d::Zero();  // as PoseEstimate::covariance
  double weight = 0.0;                     // share of the total weight
  std::size_t particles = 0;
  double std_position = 0.0;  // m, sqrt of the largest position-covariance eigenvalue
  double std_rotation = 0.0;  // rad
  // Share of the scan's points with map evidence (scan_fit.hpp: RayFit) within inlier distance of a surface at
  // `pose` (ParticleFilter fills it in; NaN where not computed). Points in space the map never observed count
  // for nothing: see `coverage`.
  double inlier_ratio = std::numeric_limits<double>::quiet_NaN();
  // Map coverage: the share of the scan's points with map evidence at `pose` (1 - the share in unobserved space).
  double coverage = std::numeric_limits<double>::quiet_NaN();
  // Share of the scan's rays that pass through a wall of the map at `pose` (scan_fit.hpp: RayFit).
  double see_through_ratio = std::numeric_limits<double>::quiet_NaN();
};

// Whether a place is compact: its spreads within converged_std_xyz and converged_std_angle.
inline bool compact(const Place& h, const PoseEstimateOptions& o) {
  return h.std_position <= o.converged_std_xyz && h.std_rotation <= o.converged_std_angle;
}

// explained_share of a place at its pose.
inline double explained_share(const Place& h) { return explained_share(h.inlier_ratio, h.coverage); }

struct PoseEstimate {
  Pose pose = Pose::Identity();
  // Covariance of (x, y, z, rx, ry, rz): position in the world frame, rotation as the rotation vector of
  // mean⁻¹ · R (tangent space at the mean, body frame). Weighted over the dominant mode's particles.
  Matrix6d covariance = Matrix6d::Zero();
  double place_weight = 0.0;  // share of the total weight in the dominant place
  std::size_t place_particles = 0;
  std::size_t place_count = 0;  // connected components found: places, described or not
  double std_position = 0.0;    // m, sqrt of the largest position-covariance eigenvalue
  double std_rotation = 0.0;    // rad, likewise for rotation
  // The mode is concentrated (PoseEstimateOptions); ParticleFilter adds its own conditions (fit, persistence,
  // recovery), see particle_filter.hpp.
  bool converged = false;
  double inlier_ratio = std::numeric_limits<double>::quiet_NaN();       // of the dominant mode (places[0])
  double see_through_ratio = std::numeric_limits<double>::quiet_NaN();  // likewise
  double coverage = std::numeric_limits<double>::quiet_NaN();           // map coverage at `pose`
  // The heaviest modes, best first, at most max_places: "two rooms, 55 % / 45 %".
  std::vector<Place> places;
};

// Fills the estimate's summary from its dominant place (places[0], which must exist): pose (unless
// best_particle, whose pose the estimator sets), covariance, mode weight and particles, spreads and fits. Returns
// whether that place is concentrated by `options` (converged_weight, converged_std_xyz, converged_std_angle).
bool take_dominant_place(PoseEstimate& estimate, const PoseEstimateOptions& options);
// The same from places[index] (which must exist).
bool take_place(PoseEstimate& estimate, std::size_t index, const PoseEstimateOptions& options);

// Which place (heaviest first) the estimate reports, given where the odometry carries the last estimate
// (`prediction`): the heaviest, unless it lies elsewhere (beyond max_jump_m or max_jump_rad) and the place
// that continues the last estimate holds more than 1 / switch_ratio of its share. Then that one.
std::size_t estimate_place(const std::vector<Place>& places, const Pose& prediction, double switch_ratio,
                           double max_jump_m, double max_jump_rad);

// Weighted rotation mean (Markley); weights need not be normalized. Throws Error for an empty or zero-weight set.
Eigen::Quaterniond average_rotation(const std::vector<Eigen::Quaterniond>& rotations,
                                    const std::vector<double>& weights);

// Keeps its grid, union-find and label buffers between calls.
class PoseEstimator {
 public:
  explicit PoseEstimator(const PoseEstimateOptions& options);

  // Particles 0..n-1 with weights w (any positive scale). Particles lighter than min_relative_weight of the
  // heaviest take no part in mode finding.
  PoseEstimate estimate(const ParticleArrays& particles, const double* weights, std::size_t n);
  const PoseEstimateOptions& options() const { return options_; }
  // Particle i's place in the last estimate (an index into PoseEstimate::places), or -1 for a particle
  // of a lighter mode or of negligible weight.
  std::int32_t place_of(std::size_t particle) const;

  using Cell = std::array<int, 5>;  // x, y, z, yaw, up axis

 private:
  std::uint32_t find(std::uint32_t a);
  // The cell's number in the hash table (`key`: its hash, cell_key); a new cell gets one where `insert`, else
  // kNoCell.
  std::uint32_t cell_of(const Cell& c, std::uint64_t key, bool insert);
  // estimate()'s stages. The particles above `threshold` into cells of the (x, y, z, yaw, up axis) grid.
  void bin_particles(const ParticleArrays& p, const double* w, std::size_t n, double threshold);
  // Connected components of the cells over face neighbours (union-find, each rooted at its lowest cell).
  void join_neighbour_cells();
  // The components by weight: the heaviest max_places ranked (root_rank_); returns how many, `modes` all.
  std::size_t rank_components(std::size_t* modes);
  // The weighted sums of each of the k places' particles (the first pass of describe()).
  struct Moments {
    double weight = 0.0;
    std::size_t particles = 0;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();
    Eigen::Matrix4d rotation = Eigen::Matrix4d::Zero();  // sum w q q^T (Markley's mean)
  };
  std::vector<Moments> moments(const ParticleArrays& p, const double* w, std::size_t n, std::size_t k) const;
  // Places 0..k-1 (the heaviest components, ranked) from their particles.
  std::vector<Place> describe(const ParticleArrays& p, const double* w, std::size_t n, std::size_t k,
                              double total) const;
  PoseEstimateOptions options_;
  struct Slot {
    std::uint64_t key = 0;  // the cell's hash, 0 = empty
    std::uint32_t cell = 0;
  };
  std::vector<Slot> table_;                // open addressing; key and cell side by side: one cache line a probe
  std::vector<Cell> cells_;                // cell coordinates
  std::vector<std::uint32_t> parent_;      // union-find over cells
  std::vector<std::uint32_t> neighbours_;  // each cell's neighbour one step up x, y, z and yaw, or kNoCell
  std::vector<double> cell_weight_;
  std::vector<double> root_weight_;
  std::vector<Cell> particle_cells_;          // each particle's cell coordinates (scratch)
  std::vector<std::uint64_t> particle_keys_;  // and their hashes
  std::vector<std::uint32_t> particle_cell_;
  std::vector<std::int32_t> root_rank_;  // place index of each component root, -1 beyond max_places
  int yaw_cells_ = 12;
};

}  // namespace tsdf_mcl
