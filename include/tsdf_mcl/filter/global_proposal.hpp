#pragma once
// Where global localization and recovery draw their hypotheses. Uniform over the map's free space and over
// SO(3), a rotation lands within 10° of the true one with probability ~3e-4, so 6-DoF global localization by
// brute force needs millions of particles. The scan itself says more: its floors, ceilings and walls give a
// few candidates for the up direction and the sensor's height above the floor (scan_gravity.hpp), and with an
// up direction the azimuths of its walls, matched against the map's, give a few headings. Each candidate turns
// the search into a position on a floor of the map and one of a few yaws; shares of the hypotheses stay
// uniform (in yaw, and in everything), for scans whose structure misleads.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

#include "tsdf_mcl/filter/particle_init.hpp"
#include "tsdf_mcl/filter/scan_gravity.hpp"

namespace tsdf_mcl {

struct ProposalOptions {
  // Share of the hypotheses drawn uniformly over free space and rotations (within the user's tilt bound and
  // height band, if given): the fallback where the scan's structure misleads or shows none.
  double uniform_share = 0.1;
  double min_angle_std = 0.035;  // rad (2°): floor on a gravity candidate's tilt spread
  double min_height_std = 0.1;   // m: floor on the height spread (ramps, steps, the map's own floor errors)
  // Headings: the scan's walls, turned up onto the map's up, match the map's walls at a few yaws (four in a
  // building of right angles). Hypotheses take one of them with this spread; a share stays uniform in yaw.
  double heading_std = 0.035;  // rad (2°)
  double uniform_heading_share = 0.25;
  GravityEstimation gravity;

  void validate() const;  // throws Error naming the parameter
};

// Unit surface normals (TSDF gradients, pointing into free space) of at most ~4000 of the map's blocks.
std::vector<Eigen::Vector3f> map_surface_normals(const TsdfMap& map);

class GlobalProposal {
 public:
  // Builds the free-space and floor tables (one pass over the map) and finds the map's up axis from its
  // surface normals (maps in a frame that is not level, as SLAM systems often write them, still work).
  GlobalProposal(const TsdfMap& map, const GlobalInitOptions& init, const ProposalOptions& options);

  const FreeSpaceSampler& free_space() const { return free_space_; }
  const Eigen::Vector3f& map_up() const { return map_up_; }

  // Candidates from the structure of `scan` (sensor frame, before thinning), or from an IMU's up direction
  // (sensor frame) when given. User priors filter them: with init max_tilt < pi only candidates within that
  // angle of the sensor's z axis stay. Returns the candidates in use.
  const std::vector<GravityCandidate>& use_scan(const std::vector<Eigen::Vector3f>& scan,
                                                const std::optional<Eigen::Vector3f>& imu_up = std::nullopt);
  // Forget the scan: every hypothesis uniform (within the user's priors).
  void use_uniform() {
    candidates_.clear();
    headings_.clear();
  }
  const std::vector<GravityCandidate>& candidates() const { return candidates_; }
  const std::vector<float>& headings(std::size_t candidate) const { return headings_.at(candidate); }

  // Fills particles [begin, end) from the whole mixture; particle i draws from its own stream (seed, step, i).
  void sample(const ParticleArrays& particles, std::size_t begin, std::size_t end, std::uint64_t seed,
              std::uint64_t step) const;

  // The mixture's parts: block 0 uniform (free space x SO(3), within the user's priors), block 1 + k the
  // k-th gravity candidate. A screened search scores each block on the scan points that tell its hypotheses
  // apart (ParticleFilter::search).
  std::size_t blocks() const;
  double block_share(std::size_t block) const;  // the mixture weight of a block
  const GravityCandidate* block_candidate(std::size_t block) const {
    return block == 0 || block > candidates_.size() ? nullptr : &candidates_[block - 1];
  }
  void sample_block(std::size_t block, const ParticleArrays& particles, std::size_t begin, std::size_t end,
                    std::uint64_t seed, std::uint64_t step) const;

 private:
  Eigen::Quaternionf rotation_for(std::size_t candidate, Rng& rng) const;
  std::vector<float> headings_for(const GravityCandidate& c, const std::vector<Eigen::Vector3f>& normals) const;
  void draw(std::size_t block, Rng& rng, Eigen::Vector3f* position, Eigen::Quaternionf* rotation) const;

  GlobalInitOptions init_;
  ProposalOptions options_;
  FreeSpaceSampler free_space_;
  Eigen::Vector3f map_up_ = Eigen::Vector3f::UnitZ();
  std::vector<GravityCandidate> candidates_;
  std::vector<std::vector<float>> headings_;  // per candidate: yaws (rad) about the map's up, best first
  std::vector<double> map_walls_;             // the map's wall azimuths (1° bins, smoothed)
};

// The map's up axis: the axis near +z that its surface normals (TSDF gradients) are parallel or
// perpendicular to; +z if the map shows no such structure.
Eigen::Vector3f map_up_axis(const TsdfMap& map);

}  // namespace tsdf_mcl
