// What a chosen physical device supports and which of it the logical device
// enables: the feature chains createDevice builds, and what they make possible
// recorded on the Context.
#pragma once

#include <vector>

#include <vulkan/vulkan.h>

#include "gpu/context.hpp"

namespace tally::gpu {

bool hasExtension(const std::vector<VkExtensionProperties>& extensions, const char* name);

// The feature structs a device is queried or created with, chained from
// `features` where the version or extension has them.
struct FeatureChain {
  VkPhysicalDeviceFeatures2 features = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FEATURES_2};
  VkPhysicalDeviceVulkan11Features v11 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_1_FEATURES};
  VkPhysicalDeviceVulkan12Features v12 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES};
  VkPhysicalDeviceVulkan13Features v13 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_3_FEATURES};
  VkPhysicalDeviceShaderAtomicInt64Features atomicInt64 = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SHADER_ATOMIC_INT64_FEATURES};
  VkPhysicalDeviceFragmentShaderBarycentricFeaturesKHR barycentric = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_FRAGMENT_SHADER_BARYCENTRIC_FEATURES_KHR};
  VkPhysicalDevicePipelineExecutablePropertiesFeaturesKHR executableProperties = {
      VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PIPELINE_EXECUTABLE_PROPERTIES_FEATURES_KHR};
};

// What the chosen device supports: its version, extensions, subgroup
// properties and the feature structs the device may be created with. Filled in
// place: the feature structs chain to one another.
struct Supported {
  bool v12 = false;
  bool v13 = false;
  bool hasBarycentric = false;
  bool hasExecutableProps = false;
  bool hasAtomicInt64Ext = false;
  bool hasDriverPropsExt = false;
  bool hasPartitioned = false;  // VK_NV_shader_subgroup_partitioned
  VkPhysicalDeviceProperties2 props2 = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  VkPhysicalDeviceSubgroupProperties subgroup = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_SUBGROUP_PROPERTIES};
  VkPhysicalDeviceDriverProperties driver = {VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
  FeatureChain have;
};

// The features to enable, a fresh chain from `want` set only where supported,
// and what they make possible. Filled in place like Supported.
struct Enabled {
  FeatureChain want;
  bool atomics64 = false;
  bool extendedTypes = false;
  bool hostReset = false;
  bool bda = false;
  bool indexing = false;
};

// The chosen device's extensions, properties and supported features.
void querySupport(Context& ctx, Supported& s);
// The features the instrumentation and the renderers use, where supported,
// and the extensions that carry them.
void enableFeatures(Context& ctx, const Supported& s, Enabled& e);
// What the device can do, as the renderers and the instrumentation ask it.
void recordCapabilities(Context& ctx, const Supported& s, const Enabled& e);

}  // namespace tally::gpu
