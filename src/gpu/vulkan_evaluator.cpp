#include "tsdf_mcl/gpu/vulkan_evaluator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <optional>

#include "buffer.hpp"
#include "compute_pipeline.hpp"
#include "push_constants.hpp"
#include "shader_interface.h"
#include "tsdf_mcl/core/stopwatch.hpp"
#include "tsdf_mcl/sensor/endpoint_kernel.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"
#include "vulkan_context.hpp"
#include "vulkan_evaluator_impl.hpp"

namespace tsdf_mcl {
namespace gpu {
namespace {

const std::uint32_t kEndpointSpirv[] = {
#include "endpoint_weight.inc"
};
const std::uint32_t kEndpointSubgroupSpirv[] = {
#include "endpoint_weight_subgroup.inc"
};
const std::uint32_t kReduceSubgroupSpirv[] = {
#include "reduce_subgroup.inc"
};
const std::uint32_t kReduceSharedSpirv[] = {
#include "reduce_shared.inc"
};

std::vector<std::uint32_t> reduce_specialization() {
  std::vector<std::uint32_t> spec(RD_SPEC_COUNT);  // entry i is the constant with id i
  spec[RD_SPEC_WORKGROUP] = kReduceWorkgroup;
  spec[RD_SPEC_ITEMS_PER_THREAD] = kReduceItems;
  return spec;
}

}  // namespace

VulkanEvaluator::VulkanEvaluator(const TsdfMap& map, const EvaluatorOptions& options)
    : ctx_(std::make_unique<gpu::VulkanContext>(options)),
      map_view_(map),
      notify_validation_(!options.on_validation_message),
      map_texel_views_(options.map_texel_views) {
  if (map.empty()) throw Error("the map is empty");
  choose_layouts(options);
  try {
    create_commands_and_queries();
    upload_map(map, options.max_map_binding_bytes);
    create_pipelines(options.subgroup_reduction);
    allocate_descriptor_sets();
    reserve(1024, 1024);
  } catch (...) {
    release();
    throw;
  }
  check_validation();
}

void VulkanEvaluator::choose_layouts(const EvaluatorOptions& options) {
  const gpu::DeviceCaps& caps = ctx_->caps();
  // Every invocation reads the same point at once. Through a uniform buffer that is one broadcast load on every
  // device; lavapipe turns each storage-buffer load into a loop over the SIMD lanes (measured: ~30 % of its
  // time), so scans that fit the uniform range (16 bytes a point) take that path.
  if (options.uniform_points) {
    uniform_point_capacity_ = std::min<std::uint64_t>(caps.max_uniform_buffer_range, 65536) / (4 * sizeof(float));
  }
  // A subgroup per particle on GPUs, an invocation per particle on CPU devices (EvaluatorOptions::weight_layout).
  const bool gpu_device = caps.type == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU ||
                          caps.type == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU ||
                          caps.type == VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU;
  switch (options.weight_layout) {
    case WeightLayout::kAuto:
      subgroup_layout_ = gpu_device && caps.subgroup_arithmetic;
      break;
    case WeightLayout::kSubgroupPerParticle:
      if (!caps.subgroup_arithmetic) throw Error(caps.name + " has no subgroup arithmetic in compute shaders");
      subgroup_layout_ = true;
      break;
    case WeightLayout::kInvocationPerParticle:
      subgroup_layout_ = false;
      break;
  }
  subgroup_layout_workgroup_ =
      std::max(kSubgroupLayoutWorkgroup, caps.subgroup_size) / caps.subgroup_size * caps.subgroup_size;
  if (subgroup_layout_ && subgroup_layout_workgroup_ > caps.max_workgroup_size_x) subgroup_layout_ = false;
}

void VulkanEvaluator::create_commands_and_queries() {
  const VkDevice dev = ctx_->device();
  const gpu::DeviceCaps& caps = ctx_->caps();
  VkCommandPoolCreateInfo pool_info{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pool_info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  pool_info.queueFamilyIndex = ctx_->queue_family();
  gpu::check(vkCreateCommandPool(dev, &pool_info, nullptr, &command_pool_), "vkCreateCommandPool");
  VkCommandBufferAllocateInfo alloc{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  alloc.commandPool = command_pool_;
  alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  alloc.commandBufferCount = 1;
  gpu::check(vkAllocateCommandBuffers(dev, &alloc, &cmd_), "vkAllocateCommandBuffers");
  VkFenceCreateInfo fence_info{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  gpu::check(vkCreateFence(dev, &fence_info, nullptr, &fence_), "vkCreateFence");
  if (caps.timestamps) {
    VkQueryPoolCreateInfo q{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    q.queryType = VK_QUERY_TYPE_TIMESTAMP;
    q.queryCount = kQueries;
    gpu::check(vkCreateQueryPool(dev, &q, nullptr, &queries_), "vkCreateQueryPool");
    ctx_->name(VK_OBJECT_TYPE_QUERY_POOL, queries_, "timestamps per pass");
  }
  if (caps.pipeline_statistics) {
    VkQueryPoolCreateInfo q{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    q.queryType = VK_QUERY_TYPE_PIPELINE_STATISTICS;
    q.queryCount = kStatQueries;
    q.pipelineStatistics = VK_QUERY_PIPELINE_STATISTIC_COMPUTE_SHADER_INVOCATIONS_BIT;
    gpu::check(vkCreateQueryPool(dev, &q, nullptr, &statistics_), "vkCreateQueryPool");
    ctx_->name(VK_OBJECT_TYPE_QUERY_POOL, statistics_, "pipeline statistics per pass");
  }
  ctx_->name(VK_OBJECT_TYPE_COMMAND_BUFFER, cmd_, "sensor update");
  ctx_->name(VK_OBJECT_TYPE_FENCE, fence_, "sensor update done");
}

void VulkanEvaluator::create_pipelines(bool subgroup_reduction) {
  const gpu::DeviceCaps& caps = ctx_->caps();
  reduce_pipeline_ = std::make_unique<gpu::ComputePipeline>(
      *ctx_,
      caps.subgroup_arithmetic && subgroup_reduction
          ? gpu::ShaderCode{kReduceSubgroupSpirv, std::size(kReduceSubgroupSpirv)}
          : gpu::ShaderCode{kReduceSharedSpirv, std::size(kReduceSharedSpirv)},
      std::vector<VkDescriptorType>(kReduceBindings, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER),
      sizeof(gpu::ReducePushConstants), reduce_specialization(), "reduce");
  // Created here rather than on first use so that the first update is not slowed by a pipeline compile.
  EndpointModel default_model;
  endpoint_pipeline(default_model, uniform_point_capacity_ > 0);
}

void VulkanEvaluator::allocate_descriptor_sets() {
  const VkDevice dev = ctx_->device();
  const VkDescriptorPoolSize sizes[3] = {
      {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2 * kStorageBindings + 6 * kReduceBindings},
      {VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, 2},
      {VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER, 2 * (kTexelBindings + kTableBindings)}};
  VkDescriptorPoolCreateInfo dp{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dp.maxSets = 8;
  dp.poolSizeCount = 3;
  dp.pPoolSizes = sizes;
  gpu::check(vkCreateDescriptorPool(dev, &dp, nullptr, &descriptor_pool_), "vkCreateDescriptorPool");
  const VkDescriptorSetLayout endpoint_layout = endpoint_pipelines_.begin()->second->set_layout();
  const VkDescriptorSetLayout layouts[8] = {endpoint_layout,
                                            endpoint_layout,
                                            reduce_pipeline_->set_layout(),
                                            reduce_pipeline_->set_layout(),
                                            reduce_pipeline_->set_layout(),
                                            reduce_pipeline_->set_layout(),
                                            reduce_pipeline_->set_layout(),
                                            reduce_pipeline_->set_layout()};
  VkDescriptorSetAllocateInfo ds{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  ds.descriptorPool = descriptor_pool_;
  ds.descriptorSetCount = 8;
  ds.pSetLayouts = layouts;
  VkDescriptorSet sets[8];
  gpu::check(vkAllocateDescriptorSets(dev, &ds, sets), "vkAllocateDescriptorSets");
  endpoint_sets_[0] = sets[0];
  endpoint_sets_[1] = sets[1];
  for (int s = 0; s < 2; ++s)
    for (int k = 0; k < 3; ++k) reduce_sets_[s][k] = sets[2 + 3 * s + k];
}

VulkanEvaluator::~VulkanEvaluator() { release(); }

// Destroys everything made on the device (also on a failed construction), before ctx_ destroys the device.
void VulkanEvaluator::release() {
  const VkDevice dev = ctx_->device();
  vkDeviceWaitIdle(dev);
  endpoint_pipelines_.clear();
  reduce_pipeline_.reset();
  if (descriptor_pool_) vkDestroyDescriptorPool(dev, descriptor_pool_, nullptr);
  if (queries_) vkDestroyQueryPool(dev, queries_, nullptr);
  if (statistics_) vkDestroyQueryPool(dev, statistics_, nullptr);
  if (fence_) vkDestroyFence(dev, fence_, nullptr);
  if (command_pool_) vkDestroyCommandPool(dev, command_pool_, nullptr);
  descriptor_pool_ = VK_NULL_HANDLE;
  queries_ = VK_NULL_HANDLE;
  statistics_ = VK_NULL_HANDLE;
  fence_ = VK_NULL_HANDLE;
  command_pool_ = VK_NULL_HANDLE;
  coarse_view_ = {};
  pool_views_.clear();
  table_view_ = {};
  table_ = {};
  coarse_ = {};
  pool_chunks_.clear();
  for (auto& b : particle_sets_) b = {};
  for (auto& b : records_) b = {};
  points_ = {};
  points_staging_ = {};
}

void VulkanEvaluator::check_validation() const {
  if (notify_validation_ && ctx_->validation_errors() > 0) {
    throw Error("Vulkan validation reported: " + ctx_->last_validation_message());
  }
}

const gpu::ComputePipeline& VulkanEvaluator::endpoint_pipeline(const EndpointModel& model, bool uniform_points) {
  const auto interpolation = static_cast<std::uint32_t>(model.interpolation);
  const auto likelihood = static_cast<std::uint32_t>(model.likelihood);
  // The subgroup layout's lanes read different points: from the storage buffer, never the uniform view.
  const std::uint32_t uniform = uniform_points && !subgroup_layout_ ? 1u : 0u;
  const std::uint32_t key = (interpolation * 2 + likelihood) * 2 + uniform;
  auto& slot = endpoint_pipelines_[key];
  if (!slot) {
    std::vector<VkDescriptorType> bindings(kEndpointBindings, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER);
    bindings[EW_BINDING_UNIFORM_POINTS] = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
    for (std::uint32_t b = 0; b < kTexelBindings + kTableBindings; ++b)
      bindings[EW_BINDING_COARSE_VIEW + b] = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
    // Entry i of the vector is the constant with id i (compute_pipeline.hpp).
    std::vector<std::uint32_t> spec(EW_SPEC_COUNT);
    spec[EW_SPEC_WORKGROUP] = subgroup_layout_ ? subgroup_layout_workgroup_ : kEndpointWorkgroup;
    spec[EW_SPEC_INTERPOLATION] = interpolation;
    spec[EW_SPEC_LIKELIHOOD] = likelihood;
    spec[EW_SPEC_CHUNK_SHIFT] = chunk_shift_;
    spec[EW_SPEC_POOL_CHUNKS] = static_cast<std::uint32_t>(pool_chunks_.size());
    spec[EW_SPEC_UNIFORM_POINTS] = uniform;
    spec[EW_SPEC_UNIFORM_POINT_CAPACITY] =
        static_cast<std::uint32_t>(std::max<std::size_t>(uniform_point_capacity_, 1));
    spec[EW_SPEC_MAP_TEXEL_VIEWS] = map_texel_views_ ? 1u : 0u;
    spec[EW_SPEC_BATCH] = kNearestBatch;
    const gpu::ShaderCode code = subgroup_layout_
                                     ? gpu::ShaderCode{kEndpointSubgroupSpirv, std::size(kEndpointSubgroupSpirv)}
                                     : gpu::ShaderCode{kEndpointSpirv, std::size(kEndpointSpirv)};
    slot = std::make_unique<gpu::ComputePipeline>(*ctx_, code, bindings, sizeof(gpu::EndpointPushConstants), spec,
                                                  "endpoint_weight");
  }
  return *slot;
}

// A subgroup per particle: workgroup / subgroupSize particles a workgroup. SPIR-V before 1.6 without
// VK_PIPELINE_SHADER_STAGE_CREATE_ALLOW_VARYING_SUBGROUP_SIZE_BIT runs compute shaders in subgroups of exactly
// subgroupSize invocations, so the shader's gl_NumSubgroups is this count.
std::uint32_t VulkanEvaluator::endpoint_groups(std::size_t n) const {
  if (!subgroup_layout_) return groups_for(n, kEndpointWorkgroup);
  return groups_for(n, subgroup_layout_workgroup_ / ctx_->caps().subgroup_size);
}

}  // namespace gpu

std::unique_ptr<SensorEvaluator> make_vulkan_evaluator(const TsdfMap& map, const EvaluatorOptions& options) {
  return std::make_unique<gpu::VulkanEvaluator>(map, options);
}

}  // namespace tsdf_mcl
