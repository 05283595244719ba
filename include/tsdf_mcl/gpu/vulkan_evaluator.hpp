#pragma once
#include <memory>

#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

// Throws Error (one line: why) if no usable Vulkan device exists.
std::unique_ptr<SensorEvaluator> make_vulkan_evaluator(const TsdfMap& map, const EvaluatorOptions& options);

}  // namespace tsdf_mcl
