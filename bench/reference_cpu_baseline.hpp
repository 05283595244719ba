#pragma once
// A straightforward implementation of the reference implementation's CPU sensor update, kept as the baseline the
// benchmark compares against: per particle a 4x4 transform, per point a float-divided cell lookup through the
// map's public API and the summed likelihood; threads over particles.
#include <vector>

#include "tsdf_mcl/sensor/endpoint_model.hpp"
#include "tsdf_mcl/sensor/sensor_evaluator.hpp"
#include "tsdf_mcl/map/tsdf_map.hpp"

namespace tsdf_mcl::bench {

void reference_cpu_weights(const TsdfMap& map, const EndpointModel& model, const ParticleArrays& particles,
                           std::size_t n, const std::vector<Eigen::Vector3f>& points);

}  // namespace tsdf_mcl::bench
