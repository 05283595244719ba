#pragma once
// Vulkan instance, device and queue, plus what the device reports about itself. Only src/gpu sees vulkan.h.
#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tsdf_mcl/sensor/sensor_evaluator.hpp"

namespace tsdf_mcl::gpu {

// Throws Error naming the call and the VkResult.
void check(VkResult result, const char* what);
const char* result_name(VkResult result);

struct DeviceCaps {
  std::string name;
  std::uint32_t api_version = 0;
  VkPhysicalDeviceType type = VK_PHYSICAL_DEVICE_TYPE_OTHER;
  std::uint32_t subgroup_size = 1;
  bool subgroup_arithmetic = false;  // basic + arithmetic ops in compute shaders
  bool timestamps = false;
  double timestamp_period_ns = 1.0;
  std::uint64_t timestamp_mask = ~0ull;
  std::uint64_t max_storage_buffer_range = 0;
  std::uint64_t max_uniform_buffer_range = 0;
  std::uint32_t max_texel_buffer_elements = 0;
  std::uint32_t max_workgroup_size_x = 0;
  std::uint32_t max_workgroup_invocations = 0;
  std::uint32_t max_workgroup_count_x = 0;
  bool unified_memory = false;  // one memory type is DEVICE_LOCAL | HOST_VISIBLE | HOST_COHERENT
  // Enabled for profiling runs (EvaluatorOptions::profile) where the device has them.
  bool pipeline_statistics = false;    // pipelineStatisticsQuery
  bool executable_properties = false;  // VK_KHR_pipeline_executable_properties
  bool debug_utils = false;            // VK_EXT_debug_utils on the instance (names and labels)
};

class VulkanContext {
 public:
  // Creates instance, picks a device (options.device_index or the best type), creates a compute queue.
  explicit VulkanContext(const EvaluatorOptions& options);
  ~VulkanContext();
  VulkanContext(const VulkanContext&) = delete;
  VulkanContext& operator=(const VulkanContext&) = delete;

  VkDevice device() const { return device_; }
  VkPhysicalDevice physical_device() const { return physical_; }
  VkQueue queue() const { return queue_; }
  std::uint32_t queue_family() const { return queue_family_; }
  const DeviceCaps& caps() const { return caps_; }

  // A memory type allowed by type_bits with all `required` flags, preferring one that also has `preferred`.
  // Returns false if none has the required flags.
  bool find_memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags required, VkMemoryPropertyFlags preferred,
                        std::uint32_t* index, VkMemoryPropertyFlags* flags) const;

  // VK_EXT_debug_utils where enabled (caps().debug_utils), no-ops otherwise: a name on an object, a label around a
  // pass in a command buffer.
  void name(VkObjectType type, std::uint64_t handle, const char* name) const;
  template <typename Handle>
  void name(VkObjectType type, Handle handle, const char* what) const {
    name(type, reinterpret_cast<std::uint64_t>(handle), what);
  }
  void begin_label(VkCommandBuffer cmd, const char* label) const;
  void end_label(VkCommandBuffer cmd) const;
  // The driver's statistics of every executable of `pipeline` (caps().executable_properties), else empty.
  std::vector<ShaderStatistics> shader_statistics(VkPipeline pipeline, const std::string& pipeline_name) const;

  // Validation messages at warning or error severity seen so far (with validation on).
  std::size_t validation_errors() const { return validation_errors_; }
  const std::string& last_validation_message() const { return last_validation_message_; }

 private:
  static VKAPI_ATTR VkBool32 VKAPI_CALL on_debug_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                         VkDebugUtilsMessageTypeFlagsEXT types,
                                                         const VkDebugUtilsMessengerCallbackDataEXT* data, void* self);
  void release();
  // The constructor's stages, in order.
  // The instance, with the validation layer and the debug messenger (synchronization validation on) where asked,
  // debug utils where profiling (names and labels for captures).
  void create_instance(bool validation, bool profile);
  // The device at `device_index`, or (-1) the best Vulkan 1.2 device: discrete, integrated, ..., CPU.
  void pick_physical_device(int device_index);
  void read_capabilities();  // name, version, subgroups, limits into caps_
  // A compute queue, one without graphics (dedicated async compute) first; its timestamp support.
  void pick_queue_family();
  // Memory types (unified where the device is integrated or the CPU), the logical device and its queue; with
  // `profile`, pipeline statistics and executable properties where the device has them.
  void create_device(bool profile);
  void load_extension_functions();  // debug labels and names, pipeline executable statistics

  VkInstance instance_ = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  VkPhysicalDevice physical_ = VK_NULL_HANDLE;
  VkDevice device_ = VK_NULL_HANDLE;
  VkQueue queue_ = VK_NULL_HANDLE;
  std::uint32_t queue_family_ = 0;
  DeviceCaps caps_;
  PFN_vkSetDebugUtilsObjectNameEXT set_object_name_ = nullptr;
  PFN_vkCmdBeginDebugUtilsLabelEXT begin_label_ = nullptr;
  PFN_vkCmdEndDebugUtilsLabelEXT end_label_ = nullptr;
  PFN_vkGetPipelineExecutablePropertiesKHR executable_properties_ = nullptr;
  PFN_vkGetPipelineExecutableStatisticsKHR executable_statistics_ = nullptr;
  VkPhysicalDeviceMemoryProperties memory_{};
  std::function<void(const std::string&)> on_validation_message_;
  std::size_t validation_errors_ = 0;
  std::string last_validation_message_;
};

// Whether validation was asked for through the environment (TSDF_MCL_VALIDATION=1): how the tests switch it on
// for every evaluator, including the ones the CLI creates.
bool validation_requested_by_environment();

}  // namespace tsdf_mcl::gpu
