#include <memory>
#include <string>

#include "tsdf_mcl/backends/make_evaluator.hpp"

#include "tsdf_mcl/cpu/cpu_evaluator.hpp"
#include "tsdf_mcl/core/error.hpp"
#ifndef TSDF_MCL_NO_VULKAN
#include "tsdf_mcl/gpu/vulkan_evaluator.hpp"
#endif

namespace tsdf_mcl {
namespace {

#ifdef TSDF_MCL_NO_VULKAN
// A build without the gpu layer (cmake -DTSDF_MCL_VULKAN=OFF): asking for Vulkan is an error, auto picks the CPU.
std::unique_ptr<SensorEvaluator> make_vulkan_evaluator(const TsdfMap&, const EvaluatorOptions&) {
  throw Error("this tsdf-mcl was built without the Vulkan backend (cmake -DTSDF_MCL_VULKAN=OFF); use backend cpu");
}
#endif

}  // namespace

std::unique_ptr<SensorEvaluator> make_evaluator(const TsdfMap& map, const EvaluatorOptions& options,
                                                std::string* note) {
  if (options.backend == Backend::kCpu) {
    auto cpu = std::make_unique<CpuEvaluator>(map, options.cpu_threads);
    if (note) *note = "backend cpu (requested): " + cpu->device_name();
    return cpu;
  }
  try {
    auto vk = make_vulkan_evaluator(map, options);
    if (note)
      *note =
          "backend vulkan" + std::string(options.backend == Backend::kAuto ? " (auto)" : "") + ": " + vk->device_name();
    return vk;
  } catch (const Error& e) {
    if (options.backend == Backend::kVulkan) throw;
    auto cpu = std::make_unique<CpuEvaluator>(map, options.cpu_threads);
    if (note) *note = "backend cpu (auto; Vulkan unavailable: " + std::string(e.what()) + "): " + cpu->device_name();
    return cpu;
  }
}

}  // namespace tsdf_mcl
