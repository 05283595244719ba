#pragma once
// The one place that knows both sensor-update backends: builds a Vulkan evaluator where a device works and the
// CPU evaluator otherwise (or as asked). Code above the sensor layer (the filter, the localizer) takes a
// SensorEvaluator& and never names a backend.
#include <memory>
#include <string>

#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl {

// With Backend::kAuto, tries Vulkan and falls back to the CPU; `note` (if given) receives one line saying which
// backend was picked and why.
std::unique_ptr<SensorEvaluator> make_evaluator(const TsdfMap& map, const EvaluatorOptions& options,
                                                std::string* note = nullptr);

}  // namespace tsdf_mcl
