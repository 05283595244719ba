// VulkanEvaluator's buffers: the map (its block pool in chunks within maxStorageBufferRange, and their texel views),
// the two particle sets, the points and the reduction's records; growing them and rewriting the descriptor sets.
#include <algorithm>
#include <cmath>
#include <cstring>

#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/stopwatch.hpp"
#include "tsdf_mcl/sensor/weight_reduction.hpp"
#include "vulkan_evaluator_impl.hpp"

namespace tsdf_mcl::gpu {

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

}  // namespace tsdf_mcl::gpu
