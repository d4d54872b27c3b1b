#include "gpu/context.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <cstring>

#include "gpu/device_features.hpp"
#include "gpu/vk_check.hpp"
#include "spirv/instrument.hpp"

namespace tally::gpu {
namespace {

// Vulkan 1.1 is the floor: subgroup operations, SPIR-V 1.3, vkGetPhysicalDeviceFeatures2.
constexpr uint32_t kMinApiVersion = VK_API_VERSION_1_1;
constexpr uint32_t kMaxApiVersion = VK_API_VERSION_1_3;
constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

const char* typeName(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return "cpu";
    default: return "other";
  }
}

// Lower is preferred: discrete, integrated, virtual, CPU, other.
int typeRank(VkPhysicalDeviceType type) {
  switch (type) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 3;
    default: return 4;
  }
}

uint32_t clampVersion(uint32_t version) {
  // Patch level does not matter for apiVersion; compare major.minor only.
  uint32_t v = VK_MAKE_API_VERSION(0, VK_API_VERSION_MAJOR(version), VK_API_VERSION_MINOR(version), 0);
  return std::min(v, kMaxApiVersion);
}

struct Candidate {
  uint32_t index = 0;
  VkPhysicalDevice handle = VK_NULL_HANDLE;
  VkPhysicalDeviceProperties properties = {};
  int queueFamily = -1;  // first family with graphics + compute
  uint32_t timestampValidBits = 0;
};

std::vector<Candidate> enumerateCandidates(VkInstance instance) {
  uint32_t count = 0;
  VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, nullptr));
  std::vector<VkPhysicalDevice> handles(count);
  VK_CHECK(vkEnumeratePhysicalDevices(instance, &count, handles.data()));
  handles.resize(count);
  std::vector<Candidate> candidates;
  for (uint32_t i = 0; i < count; ++i) {
    Candidate c;
    c.index = i;
    c.handle = handles[i];
    vkGetPhysicalDeviceProperties(c.handle, &c.properties);
    uint32_t familyCount = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(c.handle, &familyCount, nullptr);
    std::vector<VkQueueFamilyProperties> families(familyCount);
    vkGetPhysicalDeviceQueueFamilyProperties(c.handle, &familyCount, families.data());
    for (uint32_t f = 0; f < familyCount; ++f) {
      VkQueueFlags want = VK_QUEUE_GRAPHICS_BIT | VK_QUEUE_COMPUTE_BIT;
      if ((families[f].queueFlags & want) == want && families[f].queueCount > 0) {
        c.queueFamily = static_cast<int>(f);
        c.timestampValidBits = families[f].timestampValidBits;
        break;
      }
    }
    candidates.push_back(c);
  }
  return candidates;
}

std::string describeCandidate(const Candidate& c) {
  return std::to_string(c.index) + ": " + c.properties.deviceName + " [" + typeName(c.properties.deviceType) +
         ", Vulkan " + versionString(c.properties.apiVersion) + "]";
}

std::string candidateList(const std::vector<Candidate>& candidates) {
  if (candidates.empty()) return "none";
  std::string text;
  for (const auto& c : candidates) text += (text.empty() ? "" : "; ") + describeCandidate(c);
  return text;
}

// Why a device cannot run Tally, or "" when it can.
std::string unsuitable(const Candidate& c) {
  if (c.properties.apiVersion < kMinApiVersion)
    return "it supports only Vulkan " + versionString(c.properties.apiVersion);
  if (c.queueFamily < 0) return "it has no queue with graphics and compute";
  return "";
}

Result<Candidate> choose(const std::vector<Candidate>& candidates, const std::string& selector) {
  if (candidates.empty()) return makeError("no Vulkan physical device found (is a driver / ICD installed?)");
  if (!selector.empty()) {
    bool digits =
        std::all_of(selector.begin(), selector.end(), [](unsigned char ch) { return std::isdigit(ch) != 0; });
    const Candidate* match = nullptr;
    if (digits) {
      size_t index = 0;
      auto [end, ec] = std::from_chars(selector.data(), selector.data() + selector.size(), index);
      if (ec == std::errc() && end == selector.data() + selector.size() && index < candidates.size()) {
        match = &candidates[index];
      }
    } else {
      std::string needle = lower(selector);
      for (const auto& c : candidates) {
        if (lower(c.properties.deviceName).find(needle) != std::string::npos) {
          match = &c;
          break;
        }
      }
    }
    if (match == nullptr) {
      return makeError("no Vulkan device matches '" + selector +
                       "'; available: " + candidateList(candidates));
    }
    if (auto why = unsuitable(*match); !why.empty()) {
      return makeError("Vulkan device '" + describeCandidate(*match) + "' cannot be used: " + why);
    }
    return *match;
  }
  const Candidate* best = nullptr;
  for (const auto& c : candidates) {
    if (!unsuitable(c).empty()) continue;
    if (best == nullptr || typeRank(c.properties.deviceType) < typeRank(best->properties.deviceType))
      best = &c;
  }
  if (best == nullptr) {
    std::string reasons;
    for (const auto& c : candidates)
      reasons += (reasons.empty() ? "" : "; ") + describeCandidate(c) + ": " + unsuitable(c);
    return makeError("no usable Vulkan device (" + reasons + ")");
  }
  return *best;
}

VKAPI_ATTR VkBool32 VKAPI_CALL debugCallback(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                             VkDebugUtilsMessageTypeFlagsEXT,
                                             const VkDebugUtilsMessengerCallbackDataEXT* data, void*) {
  if (severity >= VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT) {
    std::fprintf(stderr, "vulkan: %s\n", data->pMessage);
  }
  return VK_FALSE;
}

void createInstance(Context& ctx, const ContextOptions& options) {
  uint32_t loaderVersion = VK_API_VERSION_1_0;
  // vkEnumerateInstanceVersion exists from loader 1.1 on; a 1.0 loader lacks it.
  auto enumerateVersion = reinterpret_cast<PFN_vkEnumerateInstanceVersion>(
      vkGetInstanceProcAddr(VK_NULL_HANDLE, "vkEnumerateInstanceVersion"));
  if (enumerateVersion != nullptr) VK_CHECK(enumerateVersion(&loaderVersion));
  if (loaderVersion < kMinApiVersion) {
    throw std::runtime_error("the Vulkan loader supports only Vulkan " + versionString(loaderVersion) +
                             "; Tally needs 1.1");
  }
  ctx.apiVersion = clampVersion(loaderVersion);

  std::vector<const char*> layers;
  std::vector<const char*> extensions;
  // VK_EXT_debug_utils whenever the loader (or an implicit layer) offers it:
  // the renderers name their images, buffers and passes with it.
  bool debugUtils = false;
  {
    uint32_t count = 0;
    VK_CHECK(vkEnumerateInstanceExtensionProperties(nullptr, &count, nullptr));
    std::vector<VkExtensionProperties> available(count);
    VK_CHECK(vkEnumerateInstanceExtensionProperties(nullptr, &count, available.data()));
    available.resize(count);
    debugUtils = hasExtension(available, VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  }
  if (options.validation) {
    uint32_t count = 0;
    VK_CHECK(vkEnumerateInstanceLayerProperties(&count, nullptr));
    std::vector<VkLayerProperties> available(count);
    VK_CHECK(vkEnumerateInstanceLayerProperties(&count, available.data()));
    available.resize(count);
    for (const auto& layer : available) {
      if (std::strcmp(layer.layerName, kValidationLayer) == 0) {
        layers.push_back(kValidationLayer);
        debugUtils = true;  // the layer provides it
      }
    }
  }
  if (debugUtils) extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);

  VkApplicationInfo app = {VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = options.applicationName.c_str();
  app.pEngineName = "tally";
  app.apiVersion = ctx.apiVersion;

  VkInstanceCreateInfo info = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  info.pApplicationInfo = &app;
  info.enabledLayerCount = static_cast<uint32_t>(layers.size());
  info.ppEnabledLayerNames = layers.data();
  info.enabledExtensionCount = static_cast<uint32_t>(extensions.size());
  info.ppEnabledExtensionNames = extensions.data();
  VkResult result = vkCreateInstance(&info, nullptr, &ctx.instance);
  if (result == VK_ERROR_INCOMPATIBLE_DRIVER) {
    throw std::runtime_error("vkCreateInstance: no compatible Vulkan driver (ICD) found");
  }
  VK_CHECK(result);
  ctx.debugUtilsInstance = debugUtils;

  if (!layers.empty()) {
    auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(ctx.instance, "vkCreateDebugUtilsMessengerEXT"));
    if (create != nullptr) {
      VkDebugUtilsMessengerCreateInfoEXT messengerInfo = {
          VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
      messengerInfo.messageSeverity =
          VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
      messengerInfo.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                                  VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                                  VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
      messengerInfo.pfnUserCallback = debugCallback;
      VK_CHECK(create(ctx.instance, &messengerInfo, nullptr, &ctx.messenger));
    }
  }
}

// VK_EXT_debug_utils' naming and label commands, through the device (a layer
// in the chain sees them), else the instance; all null without the extension.
void loadDebugUtils(Context& ctx) {
  if (!ctx.debugUtilsInstance) return;
  auto load = [&ctx](const char* name) {
    PFN_vkVoidFunction f = vkGetDeviceProcAddr(ctx.device, name);
    return f != nullptr ? f : vkGetInstanceProcAddr(ctx.instance, name);
  };
  ctx.setDebugUtilsObjectName = reinterpret_cast<PFN_vkSetDebugUtilsObjectNameEXT>(load("vkSetDebugUtilsObjectNameEXT"));
  ctx.cmdBeginDebugUtilsLabel = reinterpret_cast<PFN_vkCmdBeginDebugUtilsLabelEXT>(load("vkCmdBeginDebugUtilsLabelEXT"));
  ctx.cmdEndDebugUtilsLabel = reinterpret_cast<PFN_vkCmdEndDebugUtilsLabelEXT>(load("vkCmdEndDebugUtilsLabelEXT"));
  if (ctx.cmdBeginDebugUtilsLabel == nullptr || ctx.cmdEndDebugUtilsLabel == nullptr) {
    ctx.cmdBeginDebugUtilsLabel = nullptr;  // labels come in pairs or not at all
    ctx.cmdEndDebugUtilsLabel = nullptr;
  }
}

// Queries what the chosen device supports and creates the logical device with
// the features the instrumentation and the renderers use, where present.
void createDevice(Context& ctx, const Candidate& chosen) {
  ctx.physicalDevice = chosen.handle;
  ctx.physicalDeviceIndex = chosen.index;
  ctx.queueFamily = static_cast<uint32_t>(chosen.queueFamily);
  ctx.properties = chosen.properties;
  ctx.limits = chosen.properties.limits;
  ctx.timestampPeriod = chosen.properties.limits.timestampPeriod;
  ctx.timestampValidBits = chosen.timestampValidBits;
  ctx.timestamps = chosen.timestampValidBits > 0;
  ctx.apiVersion = std::min(ctx.apiVersion, clampVersion(chosen.properties.apiVersion));
  vkGetPhysicalDeviceMemoryProperties(ctx.physicalDevice, &ctx.memoryProperties);
  Supported supported;
  querySupport(ctx, supported);
  Enabled enabled;
  enableFeatures(ctx, supported, enabled);
  recordCapabilities(ctx, supported, enabled);
  VkPhysicalDeviceFeatures2& want = enabled.want.features;

  float priority = 1.0f;
  VkDeviceQueueCreateInfo queueInfo = {VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  queueInfo.queueFamilyIndex = ctx.queueFamily;
  queueInfo.queueCount = 1;
  queueInfo.pQueuePriorities = &priority;

  std::vector<const char*> extensionNames;
  for (const auto& name : ctx.enabledExtensions) extensionNames.push_back(name.c_str());
  VkDeviceCreateInfo info = {VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  info.pNext = &want;
  info.queueCreateInfoCount = 1;
  info.pQueueCreateInfos = &queueInfo;
  info.enabledExtensionCount = static_cast<uint32_t>(extensionNames.size());
  info.ppEnabledExtensionNames = extensionNames.data();
  VK_CHECK(vkCreateDevice(ctx.physicalDevice, &info, nullptr, &ctx.device));
  vkGetDeviceQueue(ctx.device, ctx.queueFamily, 0, &ctx.queue);
  loadDebugUtils(ctx);

  VkCommandPoolCreateInfo poolInfo = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  poolInfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT | VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  poolInfo.queueFamilyIndex = ctx.queueFamily;
  VK_CHECK(vkCreateCommandPool(ctx.device, &poolInfo, nullptr, &ctx.commandPool));
}

}  // namespace

std::string versionString(uint32_t apiVersion) {
  return std::to_string(VK_API_VERSION_MAJOR(apiVersion)) + "." +
         std::to_string(VK_API_VERSION_MINOR(apiVersion)) + "." +
         std::to_string(VK_API_VERSION_PATCH(apiVersion));
}

Result<Context> createContext(const ContextOptions& options) {
  Context ctx;
  try {
    createInstance(ctx, options);
    auto chosen = choose(enumerateCandidates(ctx.instance), options.device);
    if (!chosen) {
      destroyContext(ctx);
      return makeError(chosen.error());
    }
    createDevice(ctx, *chosen);
  } catch (const std::exception& e) {
    destroyContext(ctx);
    return makeError(std::string("Vulkan setup failed: ") + e.what());
  }
  return ctx;
}

void destroyContext(Context& ctx) {
  if (ctx.device != VK_NULL_HANDLE) {
    vkDeviceWaitIdle(ctx.device);
    if (ctx.commandPool != VK_NULL_HANDLE) vkDestroyCommandPool(ctx.device, ctx.commandPool, nullptr);
    vkDestroyDevice(ctx.device, nullptr);
  }
  if (ctx.messenger != VK_NULL_HANDLE) {
    auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
        vkGetInstanceProcAddr(ctx.instance, "vkDestroyDebugUtilsMessengerEXT"));
    if (destroy != nullptr) destroy(ctx.instance, ctx.messenger, nullptr);
  }
  if (ctx.instance != VK_NULL_HANDLE) vkDestroyInstance(ctx.instance, nullptr);
  ctx = Context{};
}

Result<std::vector<std::string>> listDevices() {
  Context ctx;
  try {
    createInstance(ctx, {});
    std::vector<std::string> lines;
    for (const auto& c : enumerateCandidates(ctx.instance)) {
      std::string line = describeCandidate(c);
      if (auto why = unsuitable(c); !why.empty()) line += " (unusable: " + why + ")";
      lines.push_back(line);
    }
    destroyContext(ctx);
    return lines;
  } catch (const std::exception& e) {
    destroyContext(ctx);
    return makeError(std::string("Vulkan setup failed: ") + e.what());
  }
}

nlohmann::json describe(const Context& ctx) {
  char vendor[16];
  std::snprintf(vendor, sizeof vendor, "0x%04X", ctx.properties.vendorID);
  char deviceId[16];
  std::snprintf(deviceId, sizeof deviceId, "0x%04X", ctx.properties.deviceID);
  return {
      {"index", ctx.physicalDeviceIndex},
      {"name", ctx.properties.deviceName},
      {"type", typeName(ctx.properties.deviceType)},
      {"vendorID", vendor},
      {"deviceID", deviceId},
      {"apiVersion", versionString(ctx.properties.apiVersion)},
      {"usedApiVersion", versionString(ctx.apiVersion)},
      {"driverVersion", ctx.properties.driverVersion},
      {"driverName", ctx.driverName},
      {"driverInfo", ctx.driverInfo},
      {"timestampPeriodNs", ctx.timestampPeriod},
      {"subgroupSize", ctx.subgroupSize},
      {"features",
       {{"int64Atomics", ctx.int64Atomics},
        {"subgroupArithmetic", ctx.subgroupArithmetic},
        {"subgroupStages", ctx.subgroupStages},
        {"subgroupPartitionedStages", ctx.subgroupPartitionedStages},
        {"fragmentBarycentric", ctx.fragmentBarycentric},
        {"pipelineExecutableInfo", ctx.pipelineExecutableInfo},
        {"pipelineStatistics", ctx.pipelineStatistics},
        {"timestamps", ctx.timestamps},
        {"descriptorIndexing", ctx.descriptorIndexing},
        {"bufferDeviceAddress", ctx.bufferDeviceAddress}}},
      {"quirks", {{"volatileHelperInvocationCrashes", ctx.volatileHelperInvocationCrashes}}},
  };
}

Result<nlohmann::json> withDevice(const std::string& device,
                                  const std::function<Result<nlohmann::json>(Context&)>& work) {
  ContextOptions contextOptions;
  contextOptions.device = device;
  auto created = createContext(contextOptions);
  if (!created) return makeError("device: " + created.error());
  Context ctx = std::move(created).value();
  struct ContextGuard {
    Context& ctx;
    ~ContextGuard() { destroyContext(ctx); }
  } guard{ctx};
  return work(ctx);
}

}  // namespace tally::gpu
