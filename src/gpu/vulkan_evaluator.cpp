#include "gpu/vulkan_evaluator.hpp"

#include "tsdf_mcl/error.hpp"

namespace tsdf_mcl {

std::unique_ptr<SensorEvaluator> make_vulkan_evaluator(const TsdfMap&, const EvaluatorOptions&) {
  throw Error("the Vulkan backend is not built yet");
}

}  // namespace tsdf_mcl
