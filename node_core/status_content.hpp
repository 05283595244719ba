#pragma once
// What the core's pose, particle and status messages hold, as plain functions of the filter's step (tested alone,
// without a transport): the covariance in ROS's convention, the decimated particles, the places and rivals as text,
// and the reason for the state.
#include <array>
#include <string>
#include <vector>

#include "node_messages.hpp"
#include "tsdf_mcl/filter/particle_filter.hpp"
#include "tsdf_mcl/io/particle_snapshot.hpp"
#include "tsdf_mcl/localizer/localizer.hpp"

namespace tsdf_mcl::node {

// The library's covariance (x, y, z, then the rotation vector in the body frame at the mean) as ROS wants it (x, y,
// z, rotation about the fixed X, Y, Z axes), row-major 6 x 6.
std::array<double, 36> fixed_frame_covariance(const Pose& mean, const Matrix6d& body_covariance);

// Every k-th particle so that at most `max_particles` remain, with their weights.
PosesOut decimated_particles(const ParticleSnapshot& snapshot, std::size_t max_particles, Stamp stamp,
                             const std::string& frame_id);

// "55 % at (1.00, 2.00, 0.50, yaw 90 deg); 45 % at ..." for the best five places.
std::string places_text(const std::vector<Place>& places);
// "(1.00, 2.00, 0.50); (...)".
std::string positions_text(const std::vector<Pose>& places);

// Why the filter is in its state, in one line: the filter's reason (track_state.hpp), the rivals the ledger follows,
// the places and the best one's share, the fit and the map's coverage.
std::string state_reason(const FilterStep& step);

}  // namespace tsdf_mcl::node
