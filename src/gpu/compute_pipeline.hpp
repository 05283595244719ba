#pragma once
#include <cstdint>
#include <vector>

#include "vulkan_context.hpp"

namespace tsdf_mcl::gpu {

struct ShaderCode {
  const std::uint32_t* words;
  std::size_t word_count;
};

// One compute pipeline: buffers at set 0, bindings 0..n-1 of the given descriptor types, a push-constant block,
// and uint32 specialization constants with ids 0..k-1 (id 0 is the workgroup size by convention).
class ComputePipeline {
 public:
  // `name` labels the pipeline and its layouts for debuggers and profilers (VK_EXT_debug_utils, where enabled); the
  // driver keeps shader statistics for it in profiling runs (VulkanContext::shader_statistics).
  ComputePipeline(const VulkanContext& ctx, ShaderCode code, const std::vector<VkDescriptorType>& bindings,
                  std::uint32_t push_constant_bytes, const std::vector<std::uint32_t>& specialization,
                  const char* name);
  ~ComputePipeline();
  ComputePipeline(const ComputePipeline&) = delete;
  ComputePipeline& operator=(const ComputePipeline&) = delete;

  VkPipeline pipeline() const { return pipeline_; }
  VkPipelineLayout layout() const { return layout_; }
  VkDescriptorSetLayout set_layout() const { return set_layout_; }
  std::uint32_t bindings() const { return bindings_; }

 private:
  void release();
  VkDevice device_;
  std::uint32_t bindings_;
  VkDescriptorSetLayout set_layout_ = VK_NULL_HANDLE;
  VkPipelineLayout layout_ = VK_NULL_HANDLE;
  VkPipeline pipeline_ = VK_NULL_HANDLE;
};

}  // namespace tsdf_mcl::gpu
