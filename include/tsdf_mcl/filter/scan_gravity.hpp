#pragma once
// Gravity and sensor height from one LiDAR scan, without an IMU: the prior that turns 6-DoF global
// localization into a yaw-and-floor-position search.
//
// Man-made scenes are built along gravity: floors and ceilings face up or down, walls face sideways. So the
// up axis, seen from the sensor, is a direction that many surface normals are parallel to and many others are
// perpendicular to. Every axis of a box-shaped room passes that test (the wall normals are axes too), and
// geometry alone cannot tell up from down, so the estimate is a short list of candidates (typically 2-6),
// each with the sensor's height above the lowest plane below it; the map decides between them. A scan with
// no such structure (a forest, a single wall) gives no candidate, and the caller falls back to rotations
// uniform over SO(3).
#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <vector>

namespace tsdf_mcl {

struct GravityEstimation {
  float min_range = 0.5f;       // m; closer points (the platform, the operator) are ignored
  float max_range = 40.0f;      // m; far points are sparse and their normals poor
  float voxel = 0.25f;          // m, grid for the surface normals (neighbourhood: 3 x 3 x 3 voxels)
  float tolerance_deg = 10.0f;  // normals within this of parallel / perpendicular support an axis
  std::size_t max_axes = 3;     // strongest axes kept (each gives an up and a down candidate)
  // An axis is kept if its support is at least this share of the best axis's support.
  float min_relative_support = 0.6f;
  std::size_t min_planar_patches = 30;  // fewer: no structure, no candidate
  float min_floor_height = 0.15f;       // m; a plane closer below the sensor is not its floor
  std::size_t min_floor_patches = 8;
  // Levels bounding the scan below (floor) and above (ceiling): the heights along `up` that all but this share
  // of the points lie above (below), accepted where at least min_level_points lie within 0.1 m of it (a plane,
  // not the tail of a sloping surface).
  float level_quantile = 0.005f;
  std::size_t min_level_points = 20;

  void validate() const;  // throws Error naming the parameter
};

struct GravityCandidate {
  Eigen::Vector3f up = Eigen::Vector3f::UnitZ();  // the world's up direction in the sensor frame (unit)
  float angle_std = 0.0f;                         // rad, standard deviation of `up`
  float support = 0.0f;  // share of the planar patches parallel or perpendicular to the axis, in [0, 1]
  // The sensor's height above the floor: the lowest large plane below it facing `up` (floor_patches > 0), or,
  // where the scan's rings are too sparse on the floor for planar patches (a VLP-16 carried at 1.5 m sees the
  // floor only beyond 5.6 m, one ring at a time), the level that bounds the scan from below (floor_patches 0,
  // a wider spread: a floor seen further down, beyond a ramp or a railing, passes that test too). Absent if the
  // scan shows neither.
  bool has_height = false;
  float height = 0.0f;      // m
  float height_std = 0.0f;  // m
  std::size_t floor_patches = 0;
  // The distance from the sensor up to the level that bounds the scan from above (the ceiling); absent if
  // the scan shows none (outdoors, an atrium).
  bool has_ceiling = false;
  float ceiling = 0.0f;      // m
  float ceiling_std = 0.0f;  // m
};

struct GravityEstimate {
  std::vector<GravityCandidate> candidates;  // best first; up and down of the same axis are adjacent
  std::size_t planar_patches = 0;            // patches whose normals voted
  // Every planar patch's unit normal, turned towards the sensor (into free space, as a TSDF's gradient
  // points): with an up direction, the azimuths of the walls, which the map's walls fix up to a few yaws.
  std::vector<Eigen::Vector3f> normals;
};

// Deterministic; costs a few milliseconds for a 30k-point scan. With `known_up` (an IMU's gravity) the one
// candidate is that direction, with the floor height the scan shows along it.
GravityEstimate estimate_gravity(const std::vector<Eigen::Vector3f>& points_in_sensor_frame,
                                 const GravityEstimation& options = {},
                                 const std::optional<Eigen::Vector3f>& known_up = std::nullopt);

// The unit normals of the scan's planar patches (the ones estimate_gravity votes with), sensor frame, turned towards
// the sensor. Deterministic; a few milliseconds for a 30k-point scan.
std::vector<Eigen::Vector3f> planar_normals(const std::vector<Eigen::Vector3f>& points_in_sensor_frame,
                                            const GravityEstimation& options = {});

// The axis near `guess` that the unit normals are parallel or perpendicular to (the refinement
// estimate_gravity uses), signed like `guess`; `guess` itself if too few normals support one. Finds a map's up
// axis from its surface normals.
Eigen::Vector3f refine_up_axis(const std::vector<Eigen::Vector3f>& normals, const Eigen::Vector3f& guess,
                               float tolerance_deg = 10.0f);

}  // namespace tsdf_mcl
