#include "compute_pipeline.hpp"

namespace tsdf_mcl::gpu {

ComputePipeline::ComputePipeline(const VulkanContext& ctx, ShaderCode code,
                                 const std::vector<VkDescriptorType>& bindings, std::uint32_t push_constant_bytes,
                                 const std::vector<std::uint32_t>& specialization, const char* name)
    : device_(ctx.device()), bindings_(static_cast<std::uint32_t>(bindings.size())) {
  VkShaderModule module = VK_NULL_HANDLE;
  try {
    std::vector<VkDescriptorSetLayoutBinding> b(bindings_);
    for (std::uint32_t i = 0; i < bindings_; ++i) b[i] = {i, bindings[i], 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
    VkDescriptorSetLayoutCreateInfo set_info{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
    set_info.bindingCount = bindings_;
    set_info.pBindings = b.data();
    check(vkCreateDescriptorSetLayout(device_, &set_info, nullptr, &set_layout_), "vkCreateDescriptorSetLayout");

    VkPushConstantRange range{VK_SHADER_STAGE_COMPUTE_BIT, 0, push_constant_bytes};
    VkPipelineLayoutCreateInfo layout_info{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
    layout_info.setLayoutCount = 1;
    layout_info.pSetLayouts = &set_layout_;
    layout_info.pushConstantRangeCount = push_constant_bytes ? 1 : 0;
    layout_info.pPushConstantRanges = &range;
    check(vkCreatePipelineLayout(device_, &layout_info, nullptr, &layout_), "vkCreatePipelineLayout");

    VkShaderModuleCreateInfo module_info{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
    module_info.codeSize = code.word_count * sizeof(std::uint32_t);
    module_info.pCode = code.words;
    check(vkCreateShaderModule(device_, &module_info, nullptr, &module), "vkCreateShaderModule");

    std::vector<VkSpecializationMapEntry> entries(specialization.size());
    for (std::uint32_t i = 0; i < entries.size(); ++i) {
      entries[i] = {i, static_cast<std::uint32_t>(i * sizeof(std::uint32_t)), sizeof(std::uint32_t)};
    }
    VkSpecializationInfo spec{static_cast<std::uint32_t>(entries.size()), entries.data(),
                              specialization.size() * sizeof(std::uint32_t), specialization.data()};
    VkComputePipelineCreateInfo info{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
    info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO};
    info.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
    info.stage.module = module;
    info.stage.pName = "main";
    info.stage.pSpecializationInfo = &spec;
    info.layout = layout_;
    if (ctx.caps().executable_properties) info.flags |= VK_PIPELINE_CREATE_CAPTURE_STATISTICS_BIT_KHR;
    check(vkCreateComputePipelines(device_, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline_), "vkCreateComputePipelines");
    vkDestroyShaderModule(device_, module, nullptr);
    ctx.name(VK_OBJECT_TYPE_PIPELINE, pipeline_, name);
    ctx.name(VK_OBJECT_TYPE_PIPELINE_LAYOUT, layout_, name);
    ctx.name(VK_OBJECT_TYPE_DESCRIPTOR_SET_LAYOUT, set_layout_, name);
  } catch (...) {
    if (module) vkDestroyShaderModule(device_, module, nullptr);
    release();
    throw;
  }
}

ComputePipeline::~ComputePipeline() { release(); }

void ComputePipeline::release() {
  if (pipeline_) vkDestroyPipeline(device_, pipeline_, nullptr);
  if (layout_) vkDestroyPipelineLayout(device_, layout_, nullptr);
  if (set_layout_) vkDestroyDescriptorSetLayout(device_, set_layout_, nullptr);
  pipeline_ = VK_NULL_HANDLE;
  layout_ = VK_NULL_HANDLE;
  set_layout_ = VK_NULL_HANDLE;
}

}  // namespace tsdf_mcl::gpu
