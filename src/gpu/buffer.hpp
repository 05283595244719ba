#pragma once
#include <cstdint>

#include "vulkan_context.hpp"

namespace tsdf_mcl::gpu {

// A storage buffer with its own memory, mapped once for its lifetime when host-visible.
class Buffer {
 public:
  enum class Use {
    kDeviceLocal,  // read by shaders; filled through a staging copy unless the memory is host-visible anyway
    kHostShared,   // written / read by the host every update (particles, results): host-visible, coherent
  };

  Buffer() = default;
  Buffer(const VulkanContext& ctx, VkDeviceSize size, Use use, VkBufferUsageFlags extra_usage = 0);
  ~Buffer();
  Buffer(Buffer&& other) noexcept;
  Buffer& operator=(Buffer&& other) noexcept;
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;

  VkBuffer handle() const { return buffer_; }
  VkDeviceSize size() const { return size_; }
  void* mapped() const { return mapped_; }  // null if not host-visible
  bool host_coherent() const { return coherent_; }
  explicit operator bool() const { return buffer_ != VK_NULL_HANDLE; }

  // Makes host writes visible to the device / device writes visible to the host (no-ops when coherent).
  void flush() const;
  void invalidate() const;

 private:
  void release();
  VkDevice device_ = VK_NULL_HANDLE;
  VkBuffer buffer_ = VK_NULL_HANDLE;
  VkDeviceMemory memory_ = VK_NULL_HANDLE;
  VkDeviceSize size_ = 0;
  void* mapped_ = nullptr;
  bool coherent_ = true;
};

// A uniform texel-buffer view (R32_UINT words) of a whole buffer made with VK_BUFFER_USAGE_UNIFORM_TEXEL_BUFFER_BIT.
class TexelView {
 public:
  TexelView() = default;
  TexelView(const VulkanContext& ctx, const Buffer& buffer);
  ~TexelView();
  TexelView(TexelView&& other) noexcept;
  TexelView& operator=(TexelView&& other) noexcept;
  TexelView(const TexelView&) = delete;
  TexelView& operator=(const TexelView&) = delete;

  const VkBufferView& handle() const { return view_; }  // a reference: descriptor writes point at it

 private:
  void release();
  VkDevice device_ = VK_NULL_HANDLE;
  VkBufferView view_ = VK_NULL_HANDLE;
};

// Copies host data into a buffer: directly when it is mapped, else through a temporary staging buffer and a
// one-off command buffer (at set-up, and when the sensor model changes: the filter's searches use a wider one).
void upload(const VulkanContext& ctx, VkCommandPool pool, const Buffer& dst, const void* data, VkDeviceSize bytes);

}  // namespace tsdf_mcl::gpu
