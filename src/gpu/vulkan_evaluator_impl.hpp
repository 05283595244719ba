#pragma once
// VulkanEvaluator, the Vulkan backend's SensorEvaluator (private to src/gpu/): the class and the layout constants
// its three files share. vulkan_evaluator.cpp sets it up (layouts, commands and queries, pipelines, descriptor
// sets) and releases it; vulkan_evaluator_buffers.cpp holds the map, particle, point and record buffers and their
// uploads; vulkan_evaluator_dispatch.cpp records, submits and reads back an update, and the profiling results.
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "buffer.hpp"
#include "compute_pipeline.hpp"
#include "push_constants.hpp"
#include "shader_interface.h"
#include "tsdf_mcl/gpu/vulkan_evaluator.hpp"
#include "tsdf_mcl/sensor/endpoint_kernel.hpp"
#include "vulkan_context.hpp"

namespace tsdf_mcl::gpu {

constexpr std::uint32_t kEndpointWorkgroup = 64;         // invocation per particle
constexpr std::uint32_t kSubgroupLayoutWorkgroup = 256;  // subgroup per particle: 256 / subgroup size particles
constexpr std::uint32_t kReduceWorkgroup = 256;
constexpr std::uint32_t kReduceItems = 4;
constexpr std::uint32_t kReducePerGroup = kReduceWorkgroup * kReduceItems;
// Points whose map reads the shader issues together (invocation layout; A/B figures in docs/sensor-update.md).
constexpr std::uint32_t kNearestBatch = 16;
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

inline std::uint32_t groups_for(std::size_t n, std::uint32_t per_group) {
  return static_cast<std::uint32_t>((n + per_group - 1) / per_group);
}

class VulkanEvaluator final : public DoubleBufferedEvaluator {
 public:
  VulkanEvaluator(const TsdfMap& map, const EvaluatorOptions& options);
  ~VulkanEvaluator() override;

  std::string backend() const override { return "vulkan"; }
  std::string device_name() const override { return ctx_->caps().name; }
  std::string map_reads() const override { return map_texel_views_ ? "texel" : "storage"; }
  std::string weight_layout() const override { return subgroup_layout_ ? "subgroup" : "invocation"; }
  bool discrete_gpu() const override { return ctx_->caps().type == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU; }
  void reserve(std::size_t particles, std::size_t points) override;
  void set_points(const std::vector<Eigen::Vector3f>& points) override;
  WeightSummary evaluate(std::size_t particle_count, const EndpointModel& model,
                         const Eigen::Quaternionf& reference_rotation) override;
  void weigh(std::size_t particle_count, const EndpointModel& model) override;
  const UpdateTimings& last_timings() const override { return timings_; }
  std::vector<ShaderStatistics> shader_statistics() const override;

 private:
  ParticleArrays view(int set) override;
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
  // evaluate()'s stages: checking the call, the pipeline and uploading the likelihood table where the model changed
  // (null: nothing to weigh); the weighting pass's constants; recording the point upload and the weighting dispatch;
  // recording the tree reduction (returns the records buffer that ends with the total); ending the command buffer
  // with the results visible to the host; submitting and waiting for the fence; reading the timestamps and pipeline
  // statistics (profiling). weigh() records no reduction.
  const gpu::ComputePipeline* prepare_weighting(std::size_t n, const EndpointModel& model);
  gpu::EndpointPushConstants endpoint_push_constants(std::size_t n, const EndpointModel& model) const;
  void record_weighting(const gpu::ComputePipeline& endpoint, const gpu::EndpointPushConstants& ep, std::size_t n);
  int record_reduction(std::size_t n, const EndpointModel& model, const Eigen::Quaternionf& reference_rotation);
  void finish_recording();
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

}  // namespace tsdf_mcl::gpu
