#include "vulkan_context.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "tsdf_mcl/core/error.hpp"

namespace tsdf_mcl::gpu {

const char* result_name(VkResult r) {
  switch (r) {
    case VK_SUCCESS:
      return "VK_SUCCESS";
    case VK_NOT_READY:
      return "VK_NOT_READY";
    case VK_TIMEOUT:
      return "VK_TIMEOUT";
    case VK_INCOMPLETE:
      return "VK_INCOMPLETE";
    case VK_ERROR_OUT_OF_HOST_MEMORY:
      return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
      return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED:
      return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST:
      return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_MEMORY_MAP_FAILED:
      return "VK_ERROR_MEMORY_MAP_FAILED";
    case VK_ERROR_LAYER_NOT_PRESENT:
      return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT:
      return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT:
      return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER:
      return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_TOO_MANY_OBJECTS:
      return "VK_ERROR_TOO_MANY_OBJECTS";
    default:
      return "VkResult error";
  }
}

void check(VkResult result, const char* what) {
  if (result != VK_SUCCESS) throw Error(std::string("Vulkan: ") + what + " failed: " + result_name(result));
}

bool validation_requested_by_environment() {
  const char* v = std::getenv("TSDF_MCL_VALIDATION");
  return v != nullptr && std::strcmp(v, "0") != 0 && v[0] != '\0';
}

namespace {

bool has_layer(const char* name) {
  std::uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  return std::any_of(layers.begin(), layers.end(),
                     [&](const VkLayerProperties& l) { return !std::strcmp(l.layerName, name); });
}

bool has_instance_extension(const char* name) {
  std::uint32_t n = 0;
  vkEnumerateInstanceExtensionProperties(nullptr, &n, nullptr);
  std::vector<VkExtensionProperties> exts(n);
  vkEnumerateInstanceExtensionProperties(nullptr, &n, exts.data());
  return std::any_of(exts.begin(), exts.end(),
                     [&](const VkExtensionProperties& e) { return !std::strcmp(e.extensionName, name); });
}

bool has_device_extension(VkPhysicalDevice device, const char* name) {
  std::uint32_t n = 0;
  vkEnumerateDeviceExtensionProperties(device, nullptr, &n, nullptr);
  std::vector<VkExtensionProperties> exts(n);
  vkEnumerateDeviceExtensionProperties(device, nullptr, &n, exts.data());
  return std::any_of(exts.begin(), exts.end(),
                     [&](const VkExtensionProperties& e) { return !std::strcmp(e.extensionName, name); });
}

std::string statistic_text(const VkPipelineExecutableStatisticKHR& s) {
  switch (s.format) {
    case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_BOOL32_KHR:
      return s.value.b32 ? "true" : "false";
    case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_INT64_KHR:
      return std::to_string(s.value.i64);
    case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_UINT64_KHR:
      return std::to_string(s.value.u64);
    case VK_PIPELINE_EXECUTABLE_STATISTIC_FORMAT_FLOAT64_KHR:
      return std::to_string(s.value.f64);
    default:
      return "?";
  }
}

int type_rank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 3;
    default:
      return 4;
  }
}

}  // namespace

VKAPI_ATTR VkBool32 VKAPI_CALL VulkanContext::on_debug_message(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                                               VkDebugUtilsMessageTypeFlagsEXT,
                                                               const VkDebugUtilsMessengerCallbackDataEXT* data,
                                                               void* user) {
  auto* self = static_cast<VulkanContext*>(user);
  const std::string message = data && data->pMessage ? data->pMessage : "(no message)";
  if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
    ++self->validation_errors_;
    self->last_validation_message_ = message;
    if (self->on_validation_message_) {
      self->on_validation_message_(message);
    } else {
      std::fprintf(stderr, "vulkan validation: %s\n", message.c_str());
    }
  }
  return VK_FALSE;
}

VulkanContext::VulkanContext(const EvaluatorOptions& options) : on_validation_message_(options.on_validation_message) {
  create_instance(options.validation || validation_requested_by_environment(), options.profile);
  try {
    pick_physical_device(options.device_index);
    read_capabilities();
    pick_queue_family();
    create_device(options.profile);
    load_extension_functions();
  } catch (...) {
    release();
    throw;
  }
}

void VulkanContext::create_instance(bool validation, bool profile) {
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "tsdf-mcl";
  app.apiVersion = VK_API_VERSION_1_2;

  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  if (validation) {
    if (!has_layer("VK_LAYER_KHRONOS_validation")) {
      throw Error(
          "Vulkan validation requested but VK_LAYER_KHRONOS_validation is not installed (vulkan-validationlayers)");
    }
    if (!has_instance_extension(VK_EXT_DEBUG_UTILS_EXTENSION_NAME)) {
      throw Error("Vulkan validation requested but " VK_EXT_DEBUG_UTILS_EXTENSION_NAME " is missing");
    }
    layers.push_back("VK_LAYER_KHRONOS_validation");
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  } else if (profile && has_instance_extension(VK_EXT_DEBUG_UTILS_EXTENSION_NAME)) {
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);  // names and labels for captures
  }
  caps_.debug_utils = !extensions.empty();
  VkDebugUtilsMessengerCreateInfoEXT messenger_info{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  messenger_info.messageSeverity =
      VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  messenger_info.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                               VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  messenger_info.pfnUserCallback = &VulkanContext::on_debug_message;
  messenger_info.pUserData = this;
  // Synchronization validation catches missing barriers between the weighting and reduction dispatches.
  const VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
  VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  features.enabledValidationFeatureCount = 1;
  features.pEnabledValidationFeatures = enables;
  features.pNext = &messenger_info;

  VkInstanceCreateInfo info{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  info.pApplicationInfo = &app;
  info.enabledLayerCount = static_cast<std::uint32_t>(layers.size());
  info.ppEnabledLayerNames = layers.data();
  info.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
  info.ppEnabledExtensionNames = extensions.data();
  if (validation) info.pNext = &features;
  const VkResult created = vkCreateInstance(&info, nullptr, &instance_);
  if (created == VK_ERROR_INCOMPATIBLE_DRIVER)
    throw Error("no Vulkan driver found (install mesa-vulkan-drivers for lavapipe)");
  check(created, "vkCreateInstance");

  if (validation) {
    auto create_messenger = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkCreateDebugUtilsMessengerEXT"));
    if (create_messenger)
      check(create_messenger(instance_, &messenger_info, nullptr, &messenger_), "vkCreateDebugUtilsMessengerEXT");
  }
}

void VulkanContext::pick_physical_device(int device_index) {
  std::uint32_t count = 0;
  check(vkEnumeratePhysicalDevices(instance_, &count, nullptr), "vkEnumeratePhysicalDevices");
  if (count == 0) throw Error("no Vulkan device found");
  std::vector<VkPhysicalDevice> devices(count);
  check(vkEnumeratePhysicalDevices(instance_, &count, devices.data()), "vkEnumeratePhysicalDevices");
  if (device_index >= 0) {
    if (static_cast<std::uint32_t>(device_index) >= count) {
      throw Error("Vulkan device index " + std::to_string(device_index) + " out of range (" + std::to_string(count) +
                  " devices)");
    }
    physical_ = devices[static_cast<std::size_t>(device_index)];
  } else {
    int best = 99;
    for (VkPhysicalDevice d : devices) {
      VkPhysicalDeviceProperties p;
      vkGetPhysicalDeviceProperties(d, &p);
      if (p.apiVersion < VK_API_VERSION_1_2) continue;
      if (type_rank(p.deviceType) < best) {
        best = type_rank(p.deviceType);
        physical_ = d;
      }
    }
    if (!physical_) throw Error("no Vulkan 1.2 device found");
  }
}

void VulkanContext::read_capabilities() {
  VkPhysicalDeviceSubgroupProperties subgroup{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  VkPhysicalDeviceProperties2 props2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  props2.pNext = &subgroup;
  vkGetPhysicalDeviceProperties2(physical_, &props2);
  const VkPhysicalDeviceProperties& p = props2.properties;
  if (p.apiVersion < VK_API_VERSION_1_2)
    throw Error(std::string("Vulkan device ") + p.deviceName + " is older than Vulkan 1.2");
  caps_.name = p.deviceName;
  caps_.api_version = p.apiVersion;
  caps_.type = p.deviceType;
  caps_.subgroup_size = std::max(1u, subgroup.subgroupSize);
  caps_.subgroup_arithmetic = (subgroup.supportedStages & VK_SHADER_STAGE_COMPUTE_BIT) &&
                              (subgroup.supportedOperations & VK_SUBGROUP_FEATURE_BASIC_BIT) &&
                              (subgroup.supportedOperations & VK_SUBGROUP_FEATURE_ARITHMETIC_BIT);
  caps_.max_storage_buffer_range = p.limits.maxStorageBufferRange;
  caps_.max_uniform_buffer_range = p.limits.maxUniformBufferRange;
  caps_.max_texel_buffer_elements = p.limits.maxTexelBufferElements;
  caps_.max_workgroup_size_x = p.limits.maxComputeWorkGroupSize[0];
  caps_.max_workgroup_invocations = p.limits.maxComputeWorkGroupInvocations;
  caps_.max_workgroup_count_x = p.limits.maxComputeWorkGroupCount[0];
  caps_.timestamp_period_ns = p.limits.timestampPeriod;
}

void VulkanContext::pick_queue_family() {
  std::uint32_t families = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(physical_, &families, nullptr);
  std::vector<VkQueueFamilyProperties> family_props(families);
  vkGetPhysicalDeviceQueueFamilyProperties(physical_, &families, family_props.data());
  bool found = false;
  // Prefer a compute queue without graphics (dedicated async compute), else any compute queue.
  for (int pass = 0; pass < 2 && !found; ++pass) {
    for (std::uint32_t f = 0; f < families; ++f) {
      const VkQueueFlags flags = family_props[f].queueFlags;
      if (!(flags & VK_QUEUE_COMPUTE_BIT)) continue;
      if (pass == 0 && (flags & VK_QUEUE_GRAPHICS_BIT)) continue;
      queue_family_ = f;
      found = true;
      break;
    }
  }
  if (!found) throw Error(std::string("Vulkan device ") + caps_.name + " has no compute queue");
  const std::uint32_t valid_bits = family_props[queue_family_].timestampValidBits;
  caps_.timestamps = valid_bits > 0 && caps_.timestamp_period_ns > 0.0;
  caps_.timestamp_mask = valid_bits >= 64 ? ~0ull : ((1ull << valid_bits) - 1ull);
}

void VulkanContext::create_device(bool profile) {
  vkGetPhysicalDeviceMemoryProperties(physical_, &memory_);
  const VkMemoryPropertyFlags unified =
      VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT | VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT;
  // Discrete GPUs with resizable BAR also expose such a type, but only as a small window of VRAM; treat
  // memory as unified only where the device says it is integrated or on the CPU.
  const bool integrated =
      caps_.type == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU || caps_.type == VK_PHYSICAL_DEVICE_TYPE_CPU;
  for (std::uint32_t i = 0; i < memory_.memoryTypeCount && integrated; ++i) {
    if ((memory_.memoryTypes[i].propertyFlags & unified) == unified) caps_.unified_memory = true;
  }

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo queue_info{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  queue_info.queueFamilyIndex = queue_family_;
  queue_info.queueCount = 1;
  queue_info.pQueuePriorities = &priority;
  VkDeviceCreateInfo device_info{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  device_info.queueCreateInfoCount = 1;
  device_info.pQueueCreateInfos = &queue_info;
  // Profiling: pipeline statistics and the driver's shader statistics, each only where the device has it.
  VkPhysicalDeviceFeatures enabled{};
  VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR executable{
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR};
  std::vector<const char*> device_extensions;
  if (profile) {
    VkPhysicalDeviceFeatures available{};
    vkGetPhysicalDeviceFeatures(physical_, &available);
    enabled.pipelineStatisticsQuery = available.pipelineStatisticsQuery;
    caps_.pipeline_statistics = available.pipelineStatisticsQuery == VK_TRUE;
    if (has_device_extension(physical_, VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME)) {
      VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR query{
          VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR};
      VkPhysicalDeviceFeatures2 features2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
      features2.pNext = &query;
      vkGetPhysicalDeviceFeatures2(physical_, &features2);
      if (query.pipelineExecutableInfo) {
        executable.pipelineExecutableInfo = VK_TRUE;
        device_extensions.push_back(VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME);
        device_info.pNext = &executable;
        caps_.executable_properties = true;
      }
    }
  }
  device_info.pEnabledFeatures = &enabled;
  device_info.enabledExtensionCount = static_cast<std::uint32_t>(device_extensions.size());
  device_info.ppEnabledExtensionNames = device_extensions.data();
  check(vkCreateDevice(physical_, &device_info, nullptr, &device_), "vkCreateDevice");
  vkGetDeviceQueue(device_, queue_family_, 0, &queue_);
}

void VulkanContext::load_extension_functions() {
  if (caps_.debug_utils) {
    set_object_name_ = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(
        vkGetInstanceProcAddr(instance_, "vkSetDebugUtilsObjectNameEXT"));
    begin_label_ = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(
        vkGetInstanceProcAddr(instance_, "vkCmdBeginDebugUtilsLabelEXT"));
    end_label_ = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(
        vkGetInstanceProcAddr(instance_, "vkCmdEndDebugUtilsLabelEXT"));
  }
  if (caps_.executable_properties) {
    executable_properties_ = reinterpret_cast<PFN_vkGetPipelineExecutablePropertiesKHR>(
        vkGetDeviceProcAddr(device_, "vkGetPipelineExecutablePropertiesKHR"));
    executable_statistics_ = reinterpret_cast<PFN_vkGetPipelineExecutableStatisticsKHR>(
        vkGetDeviceProcAddr(device_, "vkGetPipelineExecutableStatisticsKHR"));
    caps_.executable_properties = executable_properties_ && executable_statistics_;
  }
}

VulkanContext::~VulkanContext() { release(); }

void VulkanContext::release() {
  if (device_) {
    vkDeviceWaitIdle(device_);
    vkDestroyDevice(device_, nullptr);
    device_ = VK_NULL_HANDLE;
  }
  if (messenger_) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(instance_, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy) destroy(instance_, messenger_, nullptr);
    messenger_ = VK_NULL_HANDLE;
  }
  if (instance_) {
    vkDestroyInstance(instance_, nullptr);
    instance_ = VK_NULL_HANDLE;
  }
}

void VulkanContext::name(VkObjectType type, std::uint64_t handle, const char* what) const {
  if (!set_object_name_ || handle == 0) return;
  VkDebugUtilsObjectNameInfoEXT info{VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT};
  info.objectType = type;
  info.objectHandle = handle;
  info.pObjectName = what;
  set_object_name_(device_, &info);
}

void VulkanContext::begin_label(VkCommandBuffer cmd, const char* label) const {
  if (!begin_label_) return;
  VkDebugUtilsLabelEXT info{VK_STRUCTURE_TYPE_DEBUG_UTILS_LABEL_EXT};
  info.pLabelName = label;
  begin_label_(cmd, &info);
}

void VulkanContext::end_label(VkCommandBuffer cmd) const {
  if (end_label_) end_label_(cmd);
}

std::vector<ShaderStatistics> VulkanContext::shader_statistics(VkPipeline pipeline,
                                                               const std::string& pipeline_name) const {
  std::vector<ShaderStatistics> out;
  if (!caps_.executable_properties || !pipeline) return out;
  VkPipelineInfoKHR info{VK_STRUCTURE_TYPE_PIPELINE_INFO_KHR};
  info.pipeline = pipeline;
  std::uint32_t n = 0;
  check(executable_properties_(device_, &info, &n, nullptr), "vkGetPipelineExecutablePropertiesKHR");
  std::vector<VkPipelineExecutablePropertiesKHR> executables(n, {VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_PROPERTIES_KHR});
  check(executable_properties_(device_, &info, &n, executables.data()), "vkGetPipelineExecutablePropertiesKHR");
  for (std::uint32_t e = 0; e < n; ++e) {
    VkPipelineExecutableInfoKHR exec{VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_INFO_KHR};
    exec.pipeline = pipeline;
    exec.executableIndex = e;
    std::uint32_t m = 0;
    check(executable_statistics_(device_, &exec, &m, nullptr), "vkGetPipelineExecutableStatisticsKHR");
    std::vector<VkPipelineExecutableStatisticKHR> stats(m, {VK_STRUCTURE_TYPE_PIPELINE_EXECUTABLE_STATISTIC_KHR});
    check(executable_statistics_(device_, &exec, &m, stats.data()), "vkGetPipelineExecutableStatisticsKHR");
    ShaderStatistics s;
    s.pipeline = pipeline_name;
    s.executable = executables[e].name;
    for (const auto& st : stats) s.values.emplace_back(st.name, statistic_text(st));
    out.push_back(std::move(s));
  }
  return out;
}

bool VulkanContext::find_memory_type(std::uint32_t type_bits, VkMemoryPropertyFlags required,
                                     VkMemoryPropertyFlags preferred, std::uint32_t* index,
                                     VkMemoryPropertyFlags* flags) const {
  int best = -1;
  for (std::uint32_t i = 0; i < memory_.memoryTypeCount; ++i) {
    if (!(type_bits & (1u << i))) continue;
    const VkMemoryPropertyFlags f = memory_.memoryTypes[i].propertyFlags;
    if ((f & required) != required) continue;
    if (best < 0 || ((f & preferred) == preferred &&
                     (memory_.memoryTypes[static_cast<std::uint32_t>(best)].propertyFlags & preferred) != preferred)) {
      best = static_cast<int>(i);
    }
  }
  if (best < 0) return false;
  *index = static_cast<std::uint32_t>(best);
  *flags = memory_.memoryTypes[*index].propertyFlags;
  return true;
}

}  // namespace tsdf_mcl::gpu
