// VulkanEvaluator's update: recording the points' copy, the weighting and the tree reduction, submitting and waiting,
// reading the total back; and the profiling results (GPU timestamps, pipeline and shader statistics).
#include <algorithm>
#include <cmath>
#include <cstring>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/stopwatch.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"
#include "vulkan_evaluator_impl.hpp"

namespace tsdf_mcl::gpu {

void VulkanEvaluator::barrier(VkAccessFlags src, VkAccessFlags dst, VkPipelineStageFlags src_stage,
                              VkPipelineStageFlags dst_stage) {
  VkMemoryBarrier b{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  b.srcAccessMask = src;
  b.dstAccessMask = dst;
  vkCmdPipelineBarrier(cmd_, src_stage, dst_stage, 0, 1, &b, 0, nullptr, 0, nullptr);
}

const gpu::ComputePipeline* VulkanEvaluator::prepare_weighting(std::size_t n, const EndpointModel& model) {
  model.validate();
  if (n > capacity_) throw Error("evaluate: particle count exceeds the reserved capacity");
  if (point_count_ == 0) throw Error("evaluate: no scan points set");
  const gpu::ComputePipeline& endpoint = endpoint_pipeline(model, point_count_ <= uniform_point_capacity_);
  if (n == 0) return nullptr;
  if (model.interpolation == Interpolation::kNearest && !(table_model_ && kernel::same_table(model, *table_model_))) {
    std::vector<float> table;
    kernel::likelihood_table(model, map_view_.quant_step, table);
    gpu::upload(*ctx_, command_pool_, table_, table.data(), table.size() * sizeof(float));
    table_model_ = model;
  }
  return &endpoint;
}

void VulkanEvaluator::weigh(std::size_t n, const EndpointModel& model) {
  const Stopwatch t0;
  const gpu::ComputePipeline* endpoint = prepare_weighting(n, model);
  if (!endpoint) return;
  record_weighting(*endpoint, endpoint_push_constants(n, model), n);
  // No reduction: its query and timestamp still close, so the profiling reads find them written.
  if (statistics_) {
    vkCmdBeginQuery(cmd_, statistics_, 1, 0);
    vkCmdEndQuery(cmd_, statistics_, 1);
  }
  if (queries_) vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, queries_, 3);
  finish_recording();
  submit_and_wait(0);
  timings_.evaluate_ms = t0.ms();
  read_gpu_timings();
  check_validation();
}

WeightSummary VulkanEvaluator::evaluate(std::size_t n, const EndpointModel& model,
                                        const Eigen::Quaternionf& reference_rotation) {
  const Stopwatch t0;
  const gpu::ComputePipeline* endpoint = prepare_weighting(n, model);
  if (!endpoint) return {};
  record_weighting(*endpoint, endpoint_push_constants(n, model), n);
  const int out = record_reduction(n, model, reference_rotation);
  finish_recording();
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
  vkCmdBindDescriptorSets(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, endpoint.layout(), 0, 1, &endpoint_sets_[active_set()],
                          0, nullptr);
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
    const VkDescriptorSet set = reduce_sets_[active_set()][level == 0 ? 0 : (out == 1 ? 1 : 2)];
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
  return out;
}

void VulkanEvaluator::finish_recording() {
  // Results and log-weights are read by the host after the fence.
  barrier(VK_ACCESS_SHADER_WRITE_BIT, VK_ACCESS_HOST_READ_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
          VK_PIPELINE_STAGE_HOST_BIT);
  gpu::check(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer");
}

void VulkanEvaluator::submit_and_wait(int out) {
  particle_sets_[active_set()].flush();
  VkSubmitInfo submit{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &cmd_;
  gpu::check(vkResetFences(ctx_->device(), 1, &fence_), "vkResetFences");
  gpu::check(vkQueueSubmit(ctx_->queue(), 1, &submit, fence_), "vkQueueSubmit");
  gpu::check(vkWaitForFences(ctx_->device(), 1, &fence_, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  particle_sets_[active_set()].invalidate();
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

}  // namespace tsdf_mcl::gpu
