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

namespace tsdf_mcl {
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

constexpr std::uint32_t kEndpointWorkgroup = 64;         // invocation per particle
constexpr std::uint32_t kSubgroupLayoutWorkgroup = 256;  // subgroup per particle: 256 / subgroup size particles
constexpr std::uint32_t kReduceWorkgroup = 256;
constexpr std::uint32_t kReduceItems = 4;
constexpr std::uint32_t kReducePerGroup = kReduceWorkgroup * kReduceItems;
constexpr std::uint32_t kNearestBatch = 4;  // points whose map reads the shader issues together (fastest measured)
// Bindings and specialization constants by name (shader_interface.h, shared with the shaders).
constexpr std::uint32_t kEndpointBindings = EW_BINDINGS;
constexpr std::uint32_t kMaxPoolChunks = EW_MAX_POOL_CHUNKS;
constexpr std::uint32_t kStorageBindings = EW_BINDING_POOL0 + EW_MAX_POOL_CHUNKS;  // particles, points, coarse, pool
constexpr std::uint32_t kTexelBindings = 1 + kMaxPoolChunks;                       // coarse and pool views
constexpr std::uint32_t kTableBindings = 1;                                        // the nearest lookup's terms
constexpr std::uint32_t kReduceBindings = RD_BINDINGS;
constexpr std::uint32_t kQueries = 4;       // before the points' copy, before weighting, after it, after reduction
constexpr std::uint32_t kStatQueries = 2;   // pipeline statistics of weighting and of reduction (profiling runs)
constexpr std::size_t kParticleArrays = 8;  // x y z qw qx qy qz log_weight
static_assert(EW_BINDING_POOL_VIEW0 == EW_BINDING_COARSE_VIEW + 1 &&
                  EW_BINDING_TABLE_VIEW == EW_BINDING_POOL_VIEW0 + EW_MAX_POOL_CHUNKS &&
                  EW_BINDINGS == EW_BINDING_TABLE_VIEW + 1,
              "the texel views follow each other: coarse, the pool chunks, the nearest lookup's table");

std::vector<std::uint32_t> reduce_specialization() {
  std::vector<std::uint32_t> spec(RD_SPEC_COUNT);  // entry i is the constant with id i
  spec[RD_SPEC_WORKGROUP] = kReduceWorkgroup;
  spec[RD_SPEC_ITEMS_PER_THREAD] = kReduceItems;
  return spec;
}

std::uint32_t groups_for(std::size_t n, std::uint32_t per_group) {
  return static_cast<std::uint32_t>((n + per_group - 1) / per_group);
}

class VulkanEvaluator final : public SensorEvaluator {
 public:
  VulkanEvaluator(const TsdfMap& map, const EvaluatorOptions& options);
  ~VulkanEvaluator() override;

  std::string backend() const override { return "vulkan"; }
  std::string device_name() const override { return ctx_->caps().name; }
  std::string map_reads() const override { return map_texel_views_ ? "texel" : "storage"; }
  std::string weight_layout() const override { return subgroup_layout_ ? "subgroup" : "invocation"; }
  bool discrete_gpu() const override { return ctx_->caps().type == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU; }
  void reserve(std::size_t particles, std::size_t points) override;
  ParticleArrays particles() override { return view(active_); }
  ParticleArrays spare_particles() override { return view(1 - active_); }
  void swap_particles() override { active_ = 1 - active_; }
  void set_points(const std::vector<Eigen::Vector3f>& points) override;
  WeightSummary evaluate(std::size_t particle_count, const EndpointModel& model,
                         const Eigen::Quaternionf& reference_rotation) override;
  const UpdateTimings& last_timings() const override { return timings_; }
  std::vector<ShaderStatistics> shader_statistics() const override;

 private:
  ParticleArrays view(int set);
  const gpu::ComputePipeline& endpoint_pipeline(const EndpointModel& model, bool uniform_points);
  std::uint32_t endpoint_groups(std::size_t n) const;
  void grow_particles(std::size_t capacity);
  void grow_points(std::size_t capacity);
  void grow_records(std::size_t particle_capacity);
  void write_descriptor_sets();
  void check_validation() const;
  void release();
  void barrier(VkAccessFlags src, VkAccessFlags dst, VkPipelineStageFlags src_stage, VkPipelineStageFlags dst_stage);
  // The constructor's stages: the weighting layout and the uniform-points path; the command buffer, fence and
  // query pools; the map's buffers (the block pool in chunks within maxStorageBufferRange) and their texel views;
  // the pipelines; the descriptor sets.
  void choose_layouts(const EvaluatorOptions& options);
  void create_commands_and_queries();
  void upload_map(const TsdfMap& map, std::uint64_t max_map_binding_bytes);
  void create_pipelines(bool subgroup_reduction);
  void allocate_descriptor_sets();
  // evaluate()'s stages: the weighting pass's constants; recording the point upload and the weighting dispatch;
  // recording the tree reduction (returns the records buffer that ends with the total); submitting and waiting for
  // the fence; reading the timestamps and pipeline statistics (profiling).
  gpu::EndpointPushConstants endpoint_push_constants(std::size_t n, const EndpointModel& model) const;
  void record_weighting(const gpu::ComputePipeline& endpoint, const gpu::EndpointPushConstants& ep, std::size_t n);
  int record_reduction(std::size_t n, const EndpointModel& model, const Eigen::Quaternionf& reference_rotation);
  void submit_and_wait(int out);
  void read_gpu_timings();

  std::unique_ptr<gpu::VulkanContext> ctx_;
  kernel::MapView map_view_;
  bool notify_validation_;
  VkCommandPool command_pool_ = VK_NULL_HANDLE;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkQueryPool queries_ = VK_NULL_HANDLE;
  VkQueryPool statistics_ = VK_NULL_HANDLE;  // compute-shader invocations per pass (profiling runs)
  VkDescriptorPool descriptor_pool_ = VK_NULL_HANDLE;

  gpu::Buffer coarse_;
  std::vector<gpu::Buffer> pool_chunks_;
  bool map_texel_views_;
  bool subgroup_layout_ = false;                 // endpoint_weight: a subgroup per particle
  std::uint32_t subgroup_layout_workgroup_ = 0;  // its workgroup: a multiple of the subgroup size
  gpu::TexelView coarse_view_;
  std::vector<gpu::TexelView> pool_views_;
  // Nearest lookup: each quantized distance's term under the current model (kernel::likelihood_table).
  gpu::Buffer table_;
  gpu::TexelView table_view_;
  std::optional<EndpointModel> table_model_;
  std::uint32_t chunk_shift_ = 0;
  gpu::Buffer particle_sets_[2];
  std::size_t capacity_ = 0;
  int active_ = 0;
  gpu::Buffer points_;          // read by the shader
  gpu::Buffer points_staging_;  // host-written copy where points_ is not host-visible (discrete GPUs)
  std::size_t point_capacity_ = 0;
  std::size_t point_count_ = 0;
  // Scans of up to this many points are read through a uniform-buffer view of the points buffer (0: never).
  std::size_t uniform_point_capacity_ = 0;
  gpu::Buffer records_[2];
  std::size_t record_capacity_ = 0;

  std::map<std::uint32_t, std::unique_ptr<gpu::ComputePipeline>> endpoint_pipelines_;
  std::unique_ptr<gpu::ComputePipeline> reduce_pipeline_;
  // Endpoint: one per particle set. Reduction: [set][0] particles -> records 0, [set][1] 0 -> 1, [set][2] 1 -> 0.
  VkDescriptorSet endpoint_sets_[2] = {VK_NULL_HANDLE, VK_NULL_HANDLE};
  VkDescriptorSet reduce_sets_[2][3] = {};
  UpdateTimings timings_;
};

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

void VulkanEvaluator::upload_map(const TsdfMap& map, std::uint64_t max_map_binding_bytes) {
  const gpu::DeviceCaps& caps = ctx_->caps();
  // The map, uploaded once: the coarse index in one buffer, the block pool split into chunks of a power-of-two
  // number of blocks so that no binding exceeds maxStorageBufferRange (128 MiB on lavapipe).
  std::uint64_t range = std::min<std::uint64_t>(caps.max_storage_buffer_range, 1ull << 30);
  if (max_map_binding_bytes > 0) range = std::min(range, max_map_binding_bytes);
  const std::uint64_t coarse_bytes = map.coarse_index().size() * sizeof(std::uint32_t);
  if (coarse_bytes > range) {
    throw Error("map coarse index (" + std::to_string(coarse_bytes >> 20) +
                " MiB) exceeds the device's storage buffer range");
  }
  const std::uint64_t block_bytes = TsdfMap::kWordsPerBlock * sizeof(std::uint32_t);
  chunk_shift_ = 0;
  while ((block_bytes << (chunk_shift_ + 1)) <= range && chunk_shift_ < 24) ++chunk_shift_;
  const std::size_t blocks_per_chunk = std::size_t{1} << chunk_shift_;
  const std::size_t blocks = map.block_count();
  const std::size_t chunks = std::max<std::size_t>(1, (blocks + blocks_per_chunk - 1) / blocks_per_chunk);
  if (chunks > kMaxPoolChunks) {
    throw Error("map block pool (" + std::to_string(blocks * block_bytes >> 20) + " MiB) exceeds " +
                std::to_string(kMaxPoolChunks) + " storage buffers of " +
                std::to_string((blocks_per_chunk * block_bytes) >> 20) + " MiB on this device");
  }
  const std::uint64_t max_texels = std::uint64_t{caps.max_texel_buffer_elements} * sizeof(std::uint32_t);
  if (coarse_bytes > max_texels || (block_bytes << chunk_shift_) > max_texels) map_texel_views_ = false;
  const VkBufferUsageFlags map_usage = VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT;
  coarse_ = gpu::Buffer(*ctx_, coarse_bytes, gpu::Buffer::Use::kDeviceLocal, map_usage);
  ctx_->name(VK_OBJECT_TYPE_BUFFER, coarse_.handle(), "map coarse index");
  gpu::upload(*ctx_, command_pool_, coarse_, map.coarse_index().data(), coarse_bytes);
  for (std::size_t c = 0; c < chunks; ++c) {
    const std::size_t first = c * blocks_per_chunk;
    const std::size_t count = std::min(blocks_per_chunk, blocks - std::min(blocks, first));
    const VkDeviceSize bytes = std::max<VkDeviceSize>(count, 1) * block_bytes;
    pool_chunks_.emplace_back(*ctx_, bytes, gpu::Buffer::Use::kDeviceLocal, map_usage);
    ctx_->name(VK_OBJECT_TYPE_BUFFER, pool_chunks_.back().handle(), "map block pool chunk");
    gpu::upload(*ctx_, command_pool_, pool_chunks_.back(), map.block_pool().data() + first * TsdfMap::kWordsPerBlock,
                count * block_bytes);
  }
  // The views are bound even when the storage bindings are read (the layout has both): they cost nothing.
  coarse_view_ = gpu::TexelView(*ctx_, coarse_);
  for (const gpu::Buffer& chunk : pool_chunks_) pool_views_.emplace_back(*ctx_, chunk);
  table_ = gpu::Buffer(*ctx_, kernel::kTableSize * sizeof(float), gpu::Buffer::Use::kDeviceLocal, map_usage);
  ctx_->name(VK_OBJECT_TYPE_BUFFER, table_.handle(), "nearest lookup terms");
  table_view_ = gpu::TexelView(*ctx_, table_);
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

ParticleArrays VulkanEvaluator::view(int set) {
  return ParticleArrays::over(static_cast<float*>(particle_sets_[set].mapped()), capacity_);
}

void VulkanEvaluator::reserve(std::size_t particles, std::size_t points) {
  bool changed = false;
  if (particles > capacity_) {
    if (endpoint_groups(particles) > ctx_->caps().max_workgroup_count_x) {
      throw Error("too many particles for one dispatch on " + ctx_->caps().name);
    }
    grow_particles(std::max(particles, capacity_ + capacity_ / 2));
    grow_records(capacity_);
    changed = true;
  }
  if (points > point_capacity_) {
    grow_points(std::max(points, point_capacity_ + point_capacity_ / 2));
    changed = true;
  }
  if (changed) write_descriptor_sets();
}

void VulkanEvaluator::grow_particles(std::size_t capacity) {
  const VkDeviceSize bytes = kParticleArrays * capacity * sizeof(float);
  for (auto& set : particle_sets_) {
    gpu::Buffer grown(*ctx_, bytes, gpu::Buffer::Use::kHostShared);
    if (!grown.mapped()) throw Error("Vulkan: particle buffer is not host-visible");
    std::memset(grown.mapped(), 0, bytes);
    if (set) {  // keep the particles: the filter may grow the set mid-run (KLD sampling)
      for (std::size_t a = 0; a < kParticleArrays; ++a) {
        std::memcpy(static_cast<float*>(grown.mapped()) + a * capacity,
                    static_cast<const float*>(set.mapped()) + a * capacity_, capacity_ * sizeof(float));
      }
    }
    grown.flush();
    set = std::move(grown);
    ctx_->name(VK_OBJECT_TYPE_BUFFER, set.handle(), "particles (structure of arrays)");
  }
  capacity_ = capacity;
}

void VulkanEvaluator::grow_points(std::size_t capacity) {
  const VkDeviceSize bytes = capacity * 4 * sizeof(float);
  // The uniform view always covers the shader's fixed-size array, so the buffer is at least that large.
  const VkDeviceSize buffer_bytes = std::max<VkDeviceSize>(bytes, uniform_point_capacity_ * 4 * sizeof(float));
  if (ctx_->caps().unified_memory) {
    points_ = gpu::Buffer(*ctx_, buffer_bytes, gpu::Buffer::Use::kHostShared, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    points_staging_ = {};
  } else {
    points_ = gpu::Buffer(*ctx_, buffer_bytes, gpu::Buffer::Use::kDeviceLocal, VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT);
    points_staging_ = gpu::Buffer(*ctx_, bytes, gpu::Buffer::Use::kHostShared);
    ctx_->name(VK_OBJECT_TYPE_BUFFER, points_staging_.handle(), "scan points (staging)");
  }
  ctx_->name(VK_OBJECT_TYPE_BUFFER, points_.handle(), "scan points");
  point_capacity_ = capacity;
  point_count_ = 0;
}

void VulkanEvaluator::grow_records(std::size_t particle_capacity) {
  const std::size_t records = std::max<std::size_t>(1, groups_for(particle_capacity, kReducePerGroup));
  if (records <= record_capacity_) return;
  for (auto& r : records_) {
    r = gpu::Buffer(*ctx_, records * gpu::kReduceRecordFloats * sizeof(float), gpu::Buffer::Use::kHostShared);
    ctx_->name(VK_OBJECT_TYPE_BUFFER, r.handle(), "reduction records");
  }
  record_capacity_ = records;
}

void VulkanEvaluator::write_descriptor_sets() {
  std::vector<VkDescriptorBufferInfo> infos;
  std::vector<VkWriteDescriptorSet> writes;
  infos.reserve(2 * kEndpointBindings + 6 * kReduceBindings);  // no reallocation: writes point into it
  auto bind = [&](VkDescriptorSet set, std::uint32_t binding, const gpu::Buffer& buffer,
                  VkDescriptorType type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER) {
    const VkDeviceSize range = type == VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER
                                   ? std::max<std::size_t>(uniform_point_capacity_, 1) * 4 * sizeof(float)
                                   : VK_WHOLE_SIZE;
    infos.push_back({buffer.handle(), 0, range});
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = binding;
    w.descriptorCount = 1;
    w.descriptorType = type;
    w.pBufferInfo = &infos.back();
    writes.push_back(w);
  };
  for (int s = 0; s < 2; ++s) {
    bind(endpoint_sets_[s], EW_BINDING_PARTICLES, particle_sets_[s]);
    bind(endpoint_sets_[s], EW_BINDING_POINTS, points_);
    bind(endpoint_sets_[s], EW_BINDING_COARSE, coarse_);
    // Unused pool bindings repeat the first chunk: they must be valid but are never read.
    for (std::uint32_t c = 0; c < kMaxPoolChunks; ++c) {
      bind(endpoint_sets_[s], EW_BINDING_POOL0 + c, pool_chunks_[c < pool_chunks_.size() ? c : 0]);
    }
    bind(endpoint_sets_[s], EW_BINDING_UNIFORM_POINTS, points_, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER);
    for (std::uint32_t b = 0; b < kTexelBindings; ++b) {
      // Like the storage bindings, unused pool views repeat the first chunk's.
      const gpu::TexelView& v = b == 0 ? coarse_view_ : pool_views_[b - 1 < pool_views_.size() ? b - 1 : 0];
      VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      w.dstSet = endpoint_sets_[s];
      w.dstBinding = EW_BINDING_COARSE_VIEW + b;
      w.descriptorCount = 1;
      w.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
      w.pTexelBufferView = &v.handle();
      writes.push_back(w);
    }
    VkWriteDescriptorSet w{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = endpoint_sets_[s];
    w.dstBinding = EW_BINDING_TABLE_VIEW;
    w.descriptorCount = 1;
    w.descriptorType = VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER;
    w.pTexelBufferView = &table_view_.handle();
    writes.push_back(w);
    bind(reduce_sets_[s][0], RD_BINDING_PARTICLES, particle_sets_[s]);
    bind(reduce_sets_[s][0], RD_BINDING_RECORDS_IN, records_[1]);
    bind(reduce_sets_[s][0], RD_BINDING_RECORDS_OUT, records_[0]);
    bind(reduce_sets_[s][1], RD_BINDING_PARTICLES, particle_sets_[s]);
    bind(reduce_sets_[s][1], RD_BINDING_RECORDS_IN, records_[0]);
    bind(reduce_sets_[s][1], RD_BINDING_RECORDS_OUT, records_[1]);
    bind(reduce_sets_[s][2], RD_BINDING_PARTICLES, particle_sets_[s]);
    bind(reduce_sets_[s][2], RD_BINDING_RECORDS_IN, records_[1]);
    bind(reduce_sets_[s][2], RD_BINDING_RECORDS_OUT, records_[0]);
  }
  vkUpdateDescriptorSets(ctx_->device(), static_cast<std::uint32_t>(writes.size()), writes.data(), 0, nullptr);
}

void VulkanEvaluator::set_points(const std::vector<Eigen::Vector3f>& points) {
  const Stopwatch t0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) throw Error("scan point " + std::to_string(i) + " is not finite");
  }
  reserve(capacity_, points.size());
  const gpu::Buffer& dst = points_staging_ ? points_staging_ : points_;
  auto* out = static_cast<float*>(dst.mapped());
  for (std::size_t i = 0; i < points.size(); ++i) {
    out[4 * i] = points[i].x();
    out[4 * i + 1] = points[i].y();
    out[4 * i + 2] = points[i].z();
    out[4 * i + 3] = 1.0f;
  }
  dst.flush();
  point_count_ = points.size();
  timings_.upload_ms = t0.ms();
}

void VulkanEvaluator::barrier(VkAccessFlags src, VkAccessFlags dst, VkPipelineStageFlags src_stage,
                              VkPipelineStageFlags dst_stage) {
  VkMemoryBarrier b{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  b.srcAccessMask = src;
  b.dstAccessMask = dst;
  vkCmdPipelineBarrier(cmd_, src_stage, dst_stage, 0, 1, &b, 0, nullptr, 0, nullptr);
}

WeightSummary VulkanEvaluator::evaluate(std::size_t n, const EndpointModel& model,
                                        const Eigen::Quaternionf& reference_rotation) {
  model.validate();
  if (n > capacity_) throw Error("evaluate: particle count exceeds the reserved capacity");
  if (point_count_ == 0) throw Error("evaluate: no scan points set");
  const Stopwatch t0;
  const gpu::ComputePipeline& endpoint = endpoint_pipeline(model, point_count_ <= uniform_point_capacity_);
  if (n == 0) return {};
  if (model.interpolation == Interpolation::kNearest && !(table_model_ && kernel::same_table(model, *table_model_))) {
    std::vector<float> table;
    kernel::likelihood_table(model, map_view_.quant_step, table);
    gpu::upload(*ctx_, command_pool_, table_, table.data(), table.size() * sizeof(float));
    table_model_ = model;
  }

  record_weighting(endpoint, endpoint_push_constants(n, model), n);
  const int out = record_reduction(n, model, reference_rotation);
  submit_and_wait(out);
  const float* r = static_cast<const float*>(records_[out].mapped());
  WeightPartial total;
  total.max_log_weight = r[0];
  total.weight_sum = r[1];
  for (int a = 0; a < 3; ++a) total.position[a] = r[2 + a];
  for (int a = 0; a < 4; ++a) total.quaternion[a] = r[5 + a];
  total.fit_sum = r[9];
  timings_.evaluate_ms = t0.ms();

  read_gpu_timings();
  check_validation();
  return total.summary();
}

gpu::EndpointPushConstants VulkanEvaluator::endpoint_push_constants(std::size_t n, const EndpointModel& model) const {
  gpu::EndpointPushConstants ep{};
  ep.particle_count = static_cast<std::uint32_t>(n);
  ep.point_count = static_cast<std::uint32_t>(point_count_);
  ep.capacity = static_cast<std::uint32_t>(capacity_);
  ep.inv_voxel = map_view_.inv_voxel;
  ep.quant_step = map_view_.quant_step;
  for (int a = 0; a < 3; ++a) {
    ep.min_voxel[a] = map_view_.min_voxel[a];
    ep.dims_voxels[a] = map_view_.dims_voxels[a];
  }
  ep.dims_blocks_x = map_view_.dims_blocks[0];
  ep.dims_blocks_y = map_view_.dims_blocks[1];
  const kernel::ModelConstants k(model);
  ep.hit_scale = k.hit_scale;
  ep.neg_inv_2s2 = k.neg_inv_2s2;
  ep.p_rand = k.p_rand;
  ep.p_unknown = k.p_unknown;
  ep.log_p_unknown = k.log_p_unknown;
  ep.weight_exponent = model.weight_exponent;

  return ep;
}

void VulkanEvaluator::record_weighting(const gpu::ComputePipeline& endpoint, const gpu::EndpointPushConstants& ep,
                                       std::size_t n) {
  gpu::check(vkResetCommandBuffer(cmd_, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo begin{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  gpu::check(vkBeginCommandBuffer(cmd_, &begin), "vkBeginCommandBuffer");
  if (queries_) vkCmdResetQueryPool(cmd_, queries_, 0, kQueries);
  if (statistics_) vkCmdResetQueryPool(cmd_, statistics_, 0, kStatQueries);
  if (queries_) vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, queries_, 0);
  if (points_staging_) {
    ctx_->begin_label(cmd_, "upload points");
    const VkBufferCopy region{0, 0, point_count_ * 4 * sizeof(float)};
    vkCmdCopyBuffer(cmd_, points_staging_.handle(), points_.handle(), 1, &region);
    barrier(VK_ACCESS_TRANSFER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
            VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
    ctx_->end_label(cmd_);
  }
  if (queries_) vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_TRANSFER_BIT, queries_, 1);
  ctx_->begin_label(cmd_, "endpoint_weight");
  if (statistics_) vkCmdBeginQuery(cmd_, statistics_, 0, 0);
  vkCmdBindPipeline(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, endpoint.pipeline());
  vkCmdBindDescriptorSets(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, endpoint.layout(), 0, 1, &endpoint_sets_[active_], 0,
                          nullptr);
  vkCmdPushConstants(cmd_, endpoint.layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(ep), &ep);
  vkCmdDispatch(cmd_, endpoint_groups(n), 1, 1);
  if (statistics_) vkCmdEndQuery(cmd_, statistics_, 0);
  barrier(VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
          VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
  if (queries_) vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, queries_, 2);
  ctx_->end_label(cmd_);
}

int VulkanEvaluator::record_reduction(std::size_t n, const EndpointModel& model,
                                      const Eigen::Quaternionf& reference_rotation) {
  const FitConstants fit = fit_constants(model, point_count_);
  gpu::ReducePushConstants rp{};
  rp.capacity = static_cast<std::uint32_t>(capacity_);
  rp.fit_scale = fit.scale;
  rp.fit_offset = fit.offset;
  rp.reference =
      glm::vec4(reference_rotation.w(), reference_rotation.x(), reference_rotation.y(), reference_rotation.z());
  ctx_->begin_label(cmd_, "reduce");
  if (statistics_) vkCmdBeginQuery(cmd_, statistics_, 1, 0);
  vkCmdBindPipeline(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, reduce_pipeline_->pipeline());
  std::size_t count = n;
  int out = 0;  // records_[out] receives this level's records
  for (std::uint32_t level = 0;; ++level) {
    const std::uint32_t groups = groups_for(count, kReducePerGroup);
    const VkDescriptorSet set = reduce_sets_[active_][level == 0 ? 0 : (out == 1 ? 1 : 2)];
    rp.count = static_cast<std::uint32_t>(count);
    rp.level = level;
    vkCmdBindDescriptorSets(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, reduce_pipeline_->layout(), 0, 1, &set, 0, nullptr);
    vkCmdPushConstants(cmd_, reduce_pipeline_->layout(), VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(rp), &rp);
    vkCmdDispatch(cmd_, groups, 1, 1);
    count = groups;
    if (count == 1) break;
    barrier(VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_SHADER_READ_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
            VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT);
    out = 1 - out;
  }
  if (statistics_) vkCmdEndQuery(cmd_, statistics_, 1);
  if (queries_) vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, queries_, 3);
  ctx_->end_label(cmd_);
  // Results and log-weights are read by the host after the fence.
  barrier(VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_HOST_READ_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
          VK_PIPELINE_STAGE_HOST_BIT);
  gpu::check(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer");
  return out;
}

void VulkanEvaluator::submit_and_wait(int out) {
  particle_sets_[active_].flush();
  VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd_;
  gpu::check(vkResetFences(ctx_->device(), 1, &fence_), "vkResetFences");
  gpu::check(vkQueueSubmit(ctx_->queue(), 1, &submit, fence_), "vkQueueSubmit");
  gpu::check(vkWaitForFences(ctx_->device(), 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  particle_sets_[active_].invalidate();
  records_[out].invalidate();
}

void VulkanEvaluator::read_gpu_timings() {
  if (queries_) {
    std::uint64_t stamps[kQueries];
    gpu::check(vkGetQueryPoolResults(ctx_->device(), queries_, 0, kQueries, sizeof(stamps), stamps,
                                     sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
               "vkGetQueryPoolResults");
    const std::uint64_t mask = ctx_->caps().timestamp_mask;
    const double ns = ctx_->caps().timestamp_period_ns;
    timings_.transfer_gpu_ms = static_cast<double>((stamps[1] - stamps[0]) & mask) * ns * 1e-6;
    timings_.weight_gpu_ms = static_cast<double>((stamps[2] - stamps[1]) & mask) * ns * 1e-6;
    timings_.reduce_gpu_ms = static_cast<double>((stamps[3] - stamps[2]) & mask) * ns * 1e-6;
  }
  if (statistics_) {
    std::uint64_t invocations[kStatQueries];
    gpu::check(vkGetQueryPoolResults(ctx_->device(), statistics_, 0, kStatQueries, sizeof(invocations), invocations,
                                     sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
               "vkGetQueryPoolResults");
    timings_.weight_invocations = invocations[0];
    timings_.reduce_invocations = invocations[1];
  }
}

std::vector<ShaderStatistics> VulkanEvaluator::shader_statistics() const {
  std::vector<ShaderStatistics> out;
  for (const auto& [key, pipeline] : endpoint_pipelines_) {
    for (ShaderStatistics& s : ctx_->shader_statistics(pipeline->pipeline(), "endpoint_weight"))
      out.push_back(std::move(s));
  }
  for (ShaderStatistics& s : ctx_->shader_statistics(reduce_pipeline_->pipeline(), "reduce"))
    out.push_back(std::move(s));
  return out;
}

}  // namespace

std::unique_ptr<SensorEvaluator> make_vulkan_evaluator(const TsdfMap& map, const EvaluatorOptions& options) {
  return std::make_unique<VulkanEvaluator>(map, options);
}

}  // namespace tsdf_mcl
