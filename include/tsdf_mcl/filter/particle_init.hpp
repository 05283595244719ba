#pragma once
// Initial particle sets. Global: positions uniform over the map's known free space, rotations uniform over
// SO(3) or over the rotations whose tilt (angle between the sensor's z axis and the world's z axis) stays
// within a bound. Local: a Gaussian around a given pose.
#include <array>
#include <cstdint>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/core/random.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl {

struct GlobalInitOptions {
  // Gravity known (IMU): roll and pitch near 0, the sensor's z axis within this angle of the world's
  // (rad). pi or more = no restriction (uniform over SO(3)).
  double max_tilt = 3.141592653589793;
  // Ground robot: the sensor's height above the floor below it (the first surface down its TSDF column)
  // lies in [min_height, max_height] m. Off unless use_height_band.
  bool use_height_band = false;
  double min_height = 0.0;
  double max_height = 2.0;
  // Minimum distance from surfaces (m), capped by the map's truncation distance.
  double min_clearance = 0.0;

  void validate() const;  // throws Error naming the parameter
};

struct LocalInitSpread {
  double sigma_xy = 0.5;                      // m
  double sigma_z = 0.1;                       // m
  double sigma_yaw = 0.2617994;               // rad (15°)
  double sigma_roll_pitch = 0.2 * 0.2617994;  // rad: a fifth of the yaw spread (localize derives it so)

  void validate() const;
};

// The free voxels that satisfy the options, gathered once per map: per block with any such voxel, a 512-bit
// mask and a running count, so sampling is a binary search plus a bit scan. The same pass lists the floors
// (free runs of voxels that start on a surface, on a lateral lattice of about kFloorCell), for hypotheses at a
// given height above the floor.
class FreeSpaceSampler {
 public:
  FreeSpaceSampler(const TsdfMap& map, const GlobalInitOptions& options);

  std::size_t candidate_voxels() const { return cumulative_.empty() ? 0 : cumulative_.back(); }
  const GlobalInitOptions& options() const { return options_; }

  // Position uniform within a uniformly chosen candidate voxel.
  Eigen::Vector3f sample_position(Rng& rng) const;
  // Uniform rotation (Shoemake), or uniform among those within max_tilt.
  Eigen::Quaternionf sample_rotation(Rng& rng) const;
  // Fills particles [begin, end) independently; particle i draws from Rng(seed, step, i).
  void sample(const ParticleArrays& particles, std::size_t begin, std::size_t end, std::uint64_t seed,
              std::uint64_t step) const;

  static constexpr float kFloorCell = 0.1f;  // m
  std::size_t floor_count() const { return floors_.size(); }
  // A position uniform over the floors' area, `height` (+ Gaussian noise of `height_std`) above the floor and
  // inside its free run; false if a few tries found none (no floor in the map is that high).
  bool sample_above_floor(Rng& rng, float height, float height_std, Eigen::Vector3f* position) const;
  // Likewise `depth` below the ceiling over those floors (the surface that ends their free run); false if a few
  // tries found none.
  bool sample_below_ceiling(Rng& rng, float depth, float depth_std, Eigen::Vector3f* position) const;

 private:
  // One free run of a voxel column: from the surface at z (m) up to top (the next surface or unknown space).
  struct Floor {
    std::int32_t vx, vy;  // voxel column
    float z, top;
    bool ceiling;  // top is a surface, not unknown space
  };
  // A position in the free run of a random floor at the height `place` picks (NaN: none), free where it lands.
  template <typename Place>
  bool sample_in_run(Rng& rng, Place&& place, Eigen::Vector3f* position) const;
  using BlockMask = std::array<std::uint64_t, 8>;  // a block's voxels by local index, a bit each
  // The constructor's stages. The walk of every voxel column (particle_init.cpp): the candidate voxels into the
  // masks of the known blocks, the floors into floors_.
  struct ColumnWalk;
  void walk_columns(const ColumnWalk& walk);
  // The blocks with candidates into block_, mask_ and cumulative_; returns the number of candidates.
  std::uint64_t compact_blocks(const std::vector<std::int64_t>& slot, const std::vector<BlockMask>& masks);
  const TsdfMap* map_;
  GlobalInitOptions options_;
  std::vector<Eigen::Vector3i> block_;     // block coordinates
  std::vector<BlockMask> mask_;            // candidate voxels
  std::vector<std::uint64_t> cumulative_;  // candidates in blocks 0..b inclusive
  std::vector<Floor> floors_;
  int floor_stride_ = 1;  // voxels between floor columns
};

// Particles [0, n) around `mean` (world_T_sensor), each from Rng(seed, step, i).
void sample_local(const ParticleArrays& particles, std::size_t n, const Pose& mean, const LocalInitSpread& spread,
                  std::uint64_t seed, std::uint64_t step);

}  // namespace tsdf_mcl
