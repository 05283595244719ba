#pragma once
// Each place of the belief refined onto the map (filter_places.cpp): its pose, its points' log-likelihoods there and
// which of them the map observed (the observation mask, scan_fit.hpp). Private to the filter layer.
#include <cstdint>
#include <functional>
#include <vector>

#include "tsdf_mcl/filter/pose_estimate.hpp"
#include "tsdf_mcl/filter/scan_fit.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"
#include "tsdf_mcl/sensor/endpoint_model.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

struct RefinedPlaces {
  std::vector<Pose> pose;
  std::vector<double> total;  // the points' log-likelihoods summed
  std::vector<std::vector<double>> point_log;
  std::vector<std::vector<std::uint8_t>> observed;  // map evidence per point, the frontier's dropped
  std::vector<RayFit> fit;
  std::size_t reference = 0;  // the best-fitting place
};

// Each group's k heaviest particles (by weight, heaviest first, ties by index; fewer where a group has fewer), in one
// pass that keeps each group's k best so far.
std::vector<std::vector<std::size_t>> heaviest_particles(const std::int32_t* group, const double* w, std::size_t n,
                                                         std::size_t groups, std::size_t k);

// Every place refined onto the map from its mean pose and from each of its `particle_starts` (a mode's mean sits off
// its place while the mode is spread, and a few Gauss-Newton steps from there may not reach it; judged at such a pose,
// the right room loses to its look-alike in one scan). The better start wins, judged on the points that end in
// observed space at both (ties: the mean); not on the whole scan's total, which counts a point in space the map never
// observed as a miss and so rewards the start that moves the scan into the mapped part.
RefinedPlaces refine_places(const TsdfMap& map, const std::vector<Place>& places, const ParticleArrays& particles,
                            const std::vector<std::vector<std::size_t>>& particle_starts,
                            const std::vector<Eigen::Vector3f>& points, const EndpointModel& plain,
                            float inlier_distance, float frontier_reach, double dead_band,
                            const std::function<WallTilt(const Pose&)>& walls_at);

}  // namespace tsdf_mcl
