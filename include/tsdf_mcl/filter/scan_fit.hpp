#pragma once
// An absolute measure of how well a scan fits the map at a pose: the share of its points that land near a
// surface. Unlike the likelihood, it means the same on every map and scan (1 = every point explained, 0 =
// none), so a threshold calibrated on data can say "this fit is implausible for a correct track".
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "tsdf_mcl/core/pose.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"
#include "tsdf_mcl/sensor/endpoint_model.hpp"

namespace tsdf_mcl {

// Share of `points` (sensor frame) whose nearest voxel at world_T_sensor holds a known distance of at most
// `max_distance` (m) in magnitude. Points in unknown space or outside the map count as not explained.
double inlier_ratio(const TsdfMap& map, const Pose& world_T_sensor, const std::vector<Eigen::Vector3f>& points,
                    float max_distance);

// What the scan's rays say about a pose, beyond where they end. A point far from every surface is weak
// evidence against a pose (an unmapped person, a door opened since mapping, a part of the building the map never
// saw); a ray that passes through a wall of the map well before its end is strong evidence: at the true pose
// the sensor saw through that wall only where glass or a change since mapping lets it. Wrong places that fit
// the scan's near surfaces well (a corridor's mirror image, a room one floor lower) see through walls with a
// large share of their rays.
//
// Map evidence: a point whose endpoint lands in space the map never observed (an unallocated block, the unknown
// sentinel) after its ray crossed only free or unknown space says nothing about the pose: a room the mapping run
// skipped, the world beyond the map's edge. It is `unobserved`. An endpoint in unknown space behind a surface
// the ray met on its way (a negative distance: the inside of a wall, which a TSDF leaves unknown beyond its
// band, or the world outside an outer wall) is evidence: a miss. So is an endpoint inside a surface, unless the
// ray reached it from the surface's back (the distance falls towards the sensor: the far face of a wall the map
// saw from the other side only, its band reaching through the wall): unobserved, a `back_face`.
struct RayFit {
  std::size_t points = 0;
  std::size_t observed = 0;     // points with map evidence (everything but the unobserved ones)
  std::size_t inliers = 0;      // endpoint within max_distance of a surface
  std::size_t see_through = 0;  // the ray entered the inside of a surface well before its endpoint
  std::size_t back_faces = 0;   // unobserved: the endpoint lies on a face the map saw from behind only
  // Share of the points with map evidence that are inliers (0 without any).
  double inlier_ratio() const { return observed ? static_cast<double>(inliers) / static_cast<double>(observed) : 0.0; }
  // Share of all points that are inliers: what a pose explains of the whole scan.
  double absolute_inlier_ratio() const {
    return points ? static_cast<double>(inliers) / static_cast<double>(points) : 0.0;
  }
  // Share of the points with map evidence: 1 = the map covers the whole scan, 0 = none of it.
  double coverage() const { return points ? static_cast<double>(observed) / static_cast<double>(points) : 0.0; }
  double see_through_ratio() const {
    return points ? static_cast<double>(see_through) / static_cast<double>(points) : 0.0;
  }
};
// m: how far before its endpoint a ray must enter a surface to see through it (ray_fit's default end_margin).
inline constexpr float kSeeThroughMargin = 0.4f;

// Marches every ray from the sensor to its endpoint through the map (steps of the map's distance where it is
// known and positive, so free space costs little). A ray counts as seeing through once it is more than two
// voxels inside a surface at a point more than `end_margin` (m) before its endpoint.
// `observed`, if given, receives one flag per point: 1 = map evidence, 0 = unobserved.
RayFit ray_fit(const TsdfMap& map, const Pose& world_T_sensor, const std::vector<Eigen::Vector3f>& points,
               float max_distance, float end_margin = kSeeThroughMargin, std::vector<std::uint8_t>* observed = nullptr);

// Paired evidence between two poses on one scan: the sum over the points with map evidence under BOTH poses of
// the log-likelihood difference (a minus b) beyond `dead_band` (what a point a little off a surface loses; the
// sign kept). A point unobserved under either pose counts for neither: a pose that pushes points out of the map
// gains nothing by it (a plain sum over each pose's own observed points would reward it with fewer negative
// terms), and a room the map never saw cannot favour a mapped look-alike.
struct PairedEvidence {
  double sum = 0.0;        // nats, positive: a explains the shared points better
  std::size_t shared = 0;  // points observed under both
};
PairedEvidence paired_evidence(const std::vector<double>& log_a, const std::vector<std::uint8_t>& observed_a,
                               const std::vector<double>& log_b, const std::vector<std::uint8_t>& observed_b,
                               double dead_band);
// What a scan says at one pose, for paired_evidence: each point's log-likelihood under `model` (weight_exponent as
// given), its map evidence from ray_fit with the frontier's points within `frontier_reach` dropped
// (drop_frontier_points; 0: none), and the fit.
struct PointEvidence {
  std::vector<double> log;
  std::vector<std::uint8_t> observed;
  RayFit fit;
};
PointEvidence point_evidence(const TsdfMap& map, const EndpointModel& model, const Pose& pose,
                             const std::vector<Eigen::Vector3f>& points, float inlier_distance, float frontier_reach);
inline PairedEvidence paired_evidence(const PointEvidence& a, const PointEvidence& b, double dead_band) {
  return paired_evidence(a.log, a.observed, b.log, b.observed, dead_band);
}

// Clears observed[j] for the points at the frontier of the map's observed space at `pose`: an endpoint within
// `reach` (m, along any axis) of space the map never observed. What a map holds there it saw once, from afar or at
// a grazing angle through a door (the upper edge of walls a ground robot saw from below, a skipped room's walls
// seen from the corridor): between two places such points decided for whichever place the map happened to see
// better, not for where the robot is. An endpoint counts as observed where its voxel is known, or where the first
// known voxel back along its ray (within three truncation lengths) lies inside or on a surface: a ray that went
// through a wall is a miss the map can judge. An endpoint in unknown space whose ray was in free space within a
// truncation length before it (before any voxel deep inside a surface) is cleared too: a hole in a surface seen only
// at a grazing angle, or the end of the observed free space. Returns how many were cleared.
std::size_t drop_frontier_points(const TsdfMap& map, const Pose& world_T_sensor,
                                 const std::vector<Eigen::Vector3f>& points, float reach,
                                 std::vector<std::uint8_t>& observed);

// The scan's walls as a measurement of the sensor's tilt beside the points: man-made walls stand vertical, so each
// wall patch's normal (sensor frame) should lie horizontal in the map at the refined pose, perpendicular to
// `world_up` (the map's up axis). A wall constrains the tilt about the horizontal axis in its plane; walls of two
// directions fix the tilt. Floors are left out: on a ramp the floor under the sensor tilts with it. Where the
// points fix the tilt (a level map around the sensor) both have their say; where they hardly do (a room whose upper
// walls the map never observed) the walls hold it.
struct WallTilt {
  std::vector<Eigen::Vector3d> normals;  // unit, sensor frame
  Eigen::Vector3d world_up = Eigen::Vector3d::UnitZ();
  // Per wall, against the points' squared distance residuals (m²): a point constrains a tilt by its squared lever
  // arm, so 3 for each of 1,000 walls weighs like 120 points 5 m away.
  double information = 0.0;
};

// The weight per wall for a refinement on `points` points, given the weight against 512 of them: in proportion, since
// the points' weight in the refinement grows with their count while the scan they are drawn from says no more.
inline double wall_information(double per_512_points, std::size_t points) {
  return per_512_points * static_cast<double>(points) / 512.0;
}

// The patches of `normals` (unit, sensor frame; a scan's planar patches) within 10° of vertical under
// `world_T_sensor`'s tilt, each weighing `information_per_wall`, their total capped at that of `full_walls` walls
// (patches of one wall are not independent measurements). Empty (no constraint) below 30 walls.
WallTilt select_walls(const std::vector<Eigen::Vector3f>& normals, const Pose& world_T_sensor,
                      const Eigen::Vector3d& world_up, double information_per_wall, std::size_t full_walls = 1000);

// The pose near `world_T_sensor` at which `points` fit the map best: a few damped Gauss-Newton steps on their
// distances (trilinear, Huber-weighted beyond 0.1 m; points in unknown space or beyond the truncation band take
// no part). Comparing two places at their refined poses compares them, not how well each one's
// particles happen to be aligned: the one with more particles has the better-placed mean. Returns the input
// pose where too few points constrain it. With `walls`, their residuals join the points' (WallTilt).
Pose refine_pose(const TsdfMap& map, const Pose& world_T_sensor, const std::vector<Eigen::Vector3f>& points,
                 int iterations = 6, const WallTilt* walls = nullptr);

}  // namespace tsdf_mcl
