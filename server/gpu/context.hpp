// Headless Vulkan context: instance, chosen physical device, logical device,
// one graphics+compute queue, and what the device can do that Tally cares
// about. Plain struct + free functions (niagara device.h style).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>
#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "gpu/resource_log.hpp"

namespace tally::gpu {

struct ContextOptions {
  // "" picks by type: discrete, then integrated, then virtual, then CPU.
  // Digits select by index in vkEnumeratePhysicalDevices order ("0");
  // anything else by case-insensitive substring of the device name ("llvmpipe").
  std::string device;
  std::string applicationName = "tally";
  // Enables VK_LAYER_KHRONOS_validation when it is installed (ignored otherwise).
  bool validation = false;
};

// What the debug-utils helpers (gpu/debug_names.hpp) were asked to do: an
// object name or a command buffer label opened or closed.
struct DebugUtilsEvent {
  enum class Kind { ObjectName, BeginLabel, EndLabel };
  Kind kind = Kind::ObjectName;
  VkObjectType objectType = VK_OBJECT_TYPE_UNKNOWN;  // ObjectName
  uint64_t handle = 0;                               // ObjectName
  VkCommandBuffer commandBuffer = VK_NULL_HANDLE;    // BeginLabel, EndLabel
  std::string name;                                  // the object's name or the label; "" for EndLabel
};

struct Context {
  // What was created and written into descriptor sets (the footprint table reads it).
  std::shared_ptr<ResourceLog> log = std::make_shared<ResourceLog>();
  VkInstance instance = VK_NULL_HANDLE;
  VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
  VkPhysicalDevice physicalDevice = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  uint32_t queueFamily = 0;
  uint32_t physicalDeviceIndex = 0;  // in vkEnumeratePhysicalDevices order
  // One-shot command buffers (submitAndWait) come from this pool; it belongs
  // to the context's thread.
  VkCommandPool commandPool = VK_NULL_HANDLE;

  uint32_t apiVersion = 0;  // the version the device was created for (min of loader, device, 1.3)
  VkPhysicalDeviceProperties properties = {};  // vendorID, deviceID, deviceName, driverVersion...
  VkPhysicalDeviceLimits limits = {};
  VkPhysicalDeviceMemoryProperties memoryProperties = {};
  std::string driverName;  // VkPhysicalDeviceDriverProperties (Vulkan 1.2), "" before
  std::string driverInfo;  // e.g. "Mesa 22.3.6 (LLVM 15.0.6)"
  VkDriverId driverID = static_cast<VkDriverId>(0);
  float timestampPeriod = 0;  // nanoseconds per timestamp tick

  // Features Tally enabled (true only when the device has them).
  bool shaderInt64 = false;
  bool int64Atomics = false;  // shaderBufferInt64Atomics: CounterWidth::Int64 possible
  bool fragmentStoresAndAtomics = false;
  bool vertexPipelineStoresAndAtomics = false;
  bool subgroupArithmetic = false;  // arithmetic + ballot + basic in subgroupStages
  uint32_t subgroupSize = 0;
  uint32_t subgroupStages = 0;               // tally::spirv::stageBit mask; 0 without subgroupArithmetic
  uint32_t subgroupPartitionedStages = 0;    // those of subgroupStages that partition (VK_NV_shader_subgroup_partitioned)
  bool shaderSubgroupExtendedTypes = false;  // 64-bit subgroup arithmetic
  bool fragmentBarycentric = false;          // VK_KHR_fragment_shader_barycentric enabled
  // VK_KHR_pipeline_executable_properties enabled: pipelines are created with
  // CAPTURE_STATISTICS and gpu::executableStatistics reads the driver's
  // figures (NVIDIA: register count, local memory, binary size).
  bool pipelineExecutableInfo = false;
  bool pipelineStatistics = false;           // pipelineStatisticsQuery
  bool timestamps = false;                   // the queue writes timestamps
  uint32_t timestampValidBits = 0;
  bool hostQueryReset = false;
  bool storageImageWriteWithoutFormat = false;
  bool storageImageReadWithoutFormat = false;
  bool bufferDeviceAddress = false;
  bool descriptorIndexing = false;  // runtime arrays + non-uniform sampled-image indexing + partially bound
  std::vector<std::string> enabledExtensions;

  // VK_EXT_debug_utils, enabled on the instance whenever the loader offers
  // it: object names and command buffer labels for tools that intercept the
  // application (a capture layer, a debugger). Null where absent: the
  // helpers in gpu/debug_names.hpp are then no-ops.
  bool debugUtilsInstance = false;  // the instance has the extension enabled
  PFN_vkSetDebugUtilsObjectNameEXT setDebugUtilsObjectName = nullptr;
  PFN_vkCmdBeginDebugUtilsLabelEXT cmdBeginDebugUtilsLabel = nullptr;
  PFN_vkCmdEndDebugUtilsLabelEXT cmdEndDebugUtilsLabel = nullptr;
  // Where set, sees every name and label the helpers are asked for, with or
  // without the extension (tests record them).
  std::function<void(const DebugUtilsEvent&)> debugUtilsHook;

  // Driver quirks Tally works around (see shaders.hpp).
  // lavapipe (seen on Mesa 22.3.6): a Volatile HelperInvocation load, which
  // subgroup counting emits in SPIR-V 1.6 fragment shaders, aborts the
  // driver's shader compiler ("Unsupported intrinsic: is_helper_invocation").
  bool volatileHelperInvocationCrashes = false;
};

// Creates everything above. Fails with a reason (no loader, no Vulkan 1.1
// device, no device matching options.device, with the list of those there are).
Result<Context> createContext(const ContextOptions& options = {});
void destroyContext(Context& ctx);

// Opens the device (as ContextOptions::device), runs `work` on it and closes it
// again, whatever `work` returns. Fails first ("device: ...") if there is no such device.
Result<nlohmann::json> withDevice(const std::string& device,
                                  const std::function<Result<nlohmann::json>(Context&)>& work);

// "0: llvmpipe (LLVM 15.0.6, 256 bits) [cpu, Vulkan 1.3.230]" per device, one a line.
Result<std::vector<std::string>> listDevices();

// The device a run used, for recording beside every result.
nlohmann::json describe(const Context& ctx);

std::string versionString(uint32_t apiVersion);

}  // namespace tally::gpu
