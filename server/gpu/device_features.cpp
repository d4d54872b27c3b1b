#include "gpu/device_features.hpp"

#include <algorithm>
#include <cstring>

#include "gpu/vk_check.hpp"
#include "spirv/instrument.hpp"

namespace tally::gpu {

namespace {

uint32_t toStageMask(VkShaderStageFlags stages) {
  using spirv::Stage;
  using spirv::stageBit;
  uint32_t mask = 0;
  if (stages & VK_SHADER_STAGE_VERTEX_BIT) mask |= stageBit(Stage::Vertex);
  if (stages & VK_SHADER_STAGE_TESSELLATION_CONTROL_BIT) mask |= stageBit(Stage::TessControl);
  if (stages & VK_SHADER_STAGE_TESSELLATION_EVALUATION_BIT) mask |= stageBit(Stage::TessEval);
  if (stages & VK_SHADER_STAGE_GEOMETRY_BIT) mask |= stageBit(Stage::Geometry);
  if (stages & VK_SHADER_STAGE_FRAGMENT_BIT) mask |= stageBit(Stage::Fragment);
  if (stages & VK_SHADER_STAGE_COMPUTE_BIT) mask |= stageBit(Stage::Compute);
  if (stages & VK_SHADER_STAGE_TASK_BIT_EXT) mask |= stageBit(Stage::Task);
  if (stages & VK_SHADER_STAGE_MESH_BIT_EXT) mask |= stageBit(Stage::Mesh);
  return mask;
}

}  // namespace

bool hasExtension(const std::vector<VkExtensionProperties>& extensions, const char* name) {
  return std::any_of(extensions.begin(), extensions.end(),
                     [&](const VkExtensionProperties& e) { return std::strcmp(e.extensionName, name) == 0; });
}

void querySupport(Context& ctx, Supported& s) {
  s.v12 = ctx.apiVersion >= VK_API_VERSION_1_2;
  s.v13 = ctx.apiVersion >= VK_API_VERSION_1_3;
  const bool v12 = s.v12, v13 = s.v13;
  auto& props2 = s.props2;
  auto& subgroup = s.subgroup;
  auto& driver = s.driver;
  auto& [have, have11, have12, have13, haveAtomic, haveBary, haveExec] = s.have;
  uint32_t extCount = 0;
  VK_CHECK(vkEnumerateDeviceExtensionProperties(ctx.physicalDevice, nullptr, &extCount, nullptr));
  std::vector<VkExtensionProperties> available(extCount);
  VK_CHECK(vkEnumerateDeviceExtensionProperties(ctx.physicalDevice, nullptr, &extCount, available.data()));
  available.resize(extCount);
  s.hasBarycentric = hasExtension(available, VK_KHR_FRAGMENT_SHADER_BARYCENTRIC_EXTENSION_NAME);
  s.hasExecutableProps = hasExtension(available, VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME);
  s.hasAtomicInt64Ext = !v12 && hasExtension(available, VK_KHR_SHADER_ATOMIC_INT64_EXTENSION_NAME);
  s.hasDriverPropsExt = !v12 && hasExtension(available, VK_KHR_DRIVER_PROPERTIES_EXTENSION_NAME);
  s.hasPartitioned = hasExtension(available, VK_NV_SHADER_SUBGROUP_PARTITIONED_EXTENSION_NAME);
  const bool hasBarycentric = s.hasBarycentric, hasExecutableProps = s.hasExecutableProps;
  const bool hasAtomicInt64Ext = s.hasAtomicInt64Ext, hasDriverPropsExt = s.hasDriverPropsExt;

  // Properties: subgroups (1.1), driver (1.2 or extension).
  props2.pNext = &subgroup;
  if (v12 || hasDriverPropsExt) subgroup.pNext = &driver;
  vkGetPhysicalDeviceProperties2(ctx.physicalDevice, &props2);
  if (v12 || hasDriverPropsExt) {
    ctx.driverName = driver.driverName;
    ctx.driverInfo = driver.driverInfo;
    ctx.driverID = driver.driverID;
  }

  void** tail = &have.pNext;
  auto append = [&tail](auto& next) {
    *tail = &next;
    tail = &next.pNext;
  };
  if (v12) {
    append(have11);
    append(have12);
  }
  if (v13) append(have13);
  if (hasAtomicInt64Ext) append(haveAtomic);
  if (hasBarycentric) append(haveBary);
  if (hasExecutableProps) append(haveExec);
  vkGetPhysicalDeviceFeatures2(ctx.physicalDevice, &have);
  if (!v12)
    haveAtomic.shaderBufferInt64Atomics = hasAtomicInt64Ext ? haveAtomic.shaderBufferInt64Atomics : VK_FALSE;
}

void enableFeatures(Context& ctx, const Supported& s, Enabled& e) {
  const bool v12 = s.v12, v13 = s.v13;
  const bool hasBarycentric = s.hasBarycentric, hasExecutableProps = s.hasExecutableProps;
  const bool hasAtomicInt64Ext = s.hasAtomicInt64Ext, hasDriverPropsExt = s.hasDriverPropsExt;
  const auto& [have, have11, have12, have13, haveAtomic, haveBary, haveExec] = s.have;
  const VkPhysicalDeviceFeatures& h = have.features;
  auto& [want, want11, want12, want13, wantAtomic, wantBary, wantExec] = e.want;
  bool& atomics64 = e.atomics64;
  bool& extendedTypes = e.extendedTypes;
  bool& hostReset = e.hostReset;
  bool& bda = e.bda;
  bool& indexing = e.indexing;
  void** tail = &want.pNext;
  auto append = [&tail](auto& next) {
    *tail = &next;
    tail = &next.pNext;
  };
  VkPhysicalDeviceFeatures& w = want.features;
  // Counters: 64-bit integers and stores/atomics from every stage.
  w.shaderInt64 = h.shaderInt64;
  w.fragmentStoresAndAtomics = h.fragmentStoresAndAtomics;
  w.vertexPipelineStoresAndAtomics = h.vertexPipelineStoresAndAtomics;
  w.pipelineStatisticsQuery = h.pipelineStatisticsQuery;
  w.shaderStorageImageWriteWithoutFormat = h.shaderStorageImageWriteWithoutFormat;
  w.shaderStorageImageReadWithoutFormat = h.shaderStorageImageReadWithoutFormat;
  w.samplerAnisotropy = h.samplerAnisotropy;
  w.shaderInt16 = h.shaderInt16;
  w.independentBlend = h.independentBlend;
  w.depthClamp = h.depthClamp;
  w.fillModeNonSolid = h.fillModeNonSolid;  // wireframe views
  w.multiDrawIndirect = h.multiDrawIndirect;
  w.drawIndirectFirstInstance = h.drawIndirectFirstInstance;
  w.shaderSampledImageArrayDynamicIndexing = h.shaderSampledImageArrayDynamicIndexing;
  w.shaderStorageBufferArrayDynamicIndexing = h.shaderStorageBufferArrayDynamicIndexing;
  // robustBufferAccess stays off: it changes what is measured (and costs time).
  if (v12) {
    want11.shaderDrawParameters = have11.shaderDrawParameters;
    want11.storageBuffer16BitAccess = have11.storageBuffer16BitAccess;
    want12.shaderBufferInt64Atomics = have12.shaderBufferInt64Atomics;
    want12.shaderSubgroupExtendedTypes = have12.shaderSubgroupExtendedTypes;
    want12.hostQueryReset = have12.hostQueryReset;
    want12.bufferDeviceAddress = have12.bufferDeviceAddress;
    want12.scalarBlockLayout = have12.scalarBlockLayout;
    want12.storageBuffer8BitAccess = have12.storageBuffer8BitAccess;
    want12.shaderInt8 = have12.shaderInt8;
    want12.shaderFloat16 = have12.shaderFloat16;
    want12.timelineSemaphore = have12.timelineSemaphore;
    want12.drawIndirectCount = have12.drawIndirectCount;
    want12.vulkanMemoryModel = have12.vulkanMemoryModel;
    want12.vulkanMemoryModelDeviceScope = have12.vulkanMemoryModelDeviceScope;
    indexing = have12.runtimeDescriptorArray && have12.shaderSampledImageArrayNonUniformIndexing &&
               have12.descriptorBindingPartiallyBound;
    if (indexing) {
      want12.descriptorIndexing = have12.descriptorIndexing;
      want12.runtimeDescriptorArray = VK_TRUE;
      want12.shaderSampledImageArrayNonUniformIndexing = VK_TRUE;
      want12.descriptorBindingPartiallyBound = VK_TRUE;
      want12.descriptorBindingVariableDescriptorCount = have12.descriptorBindingVariableDescriptorCount;
      want12.descriptorBindingSampledImageUpdateAfterBind =
          have12.descriptorBindingSampledImageUpdateAfterBind;
    }
    atomics64 = have12.shaderBufferInt64Atomics;
    extendedTypes = have12.shaderSubgroupExtendedTypes;
    hostReset = have12.hostQueryReset;
    bda = have12.bufferDeviceAddress;
    append(want11);
    append(want12);
  } else if (hasAtomicInt64Ext) {
    wantAtomic.shaderBufferInt64Atomics = haveAtomic.shaderBufferInt64Atomics;
    atomics64 = haveAtomic.shaderBufferInt64Atomics;
    append(wantAtomic);
    ctx.enabledExtensions.push_back(VK_KHR_SHADER_ATOMIC_INT64_EXTENSION_NAME);
  }
  if (v13) {
    want13.synchronization2 = have13.synchronization2;
    want13.dynamicRendering = have13.dynamicRendering;
    want13.maintenance4 = have13.maintenance4;
    // Alpha-tested and test shaders may demote instead of discarding.
    want13.shaderDemoteToHelperInvocation = have13.shaderDemoteToHelperInvocation;
    append(want13);
  }
  if (hasBarycentric && haveBary.fragmentShaderBarycentric) {
    wantBary.fragmentShaderBarycentric = VK_TRUE;
    append(wantBary);
    ctx.enabledExtensions.push_back(VK_KHR_FRAGMENT_SHADER_BARYCENTRIC_EXTENSION_NAME);
    ctx.fragmentBarycentric = true;
  }
  if (hasDriverPropsExt) ctx.enabledExtensions.push_back(VK_KHR_DRIVER_PROPERTIES_EXTENSION_NAME);
  // Accumulate partitions a subgroup by descriptor index where it can (spirv::InstrumentOptions::partitionedStages).
  if (s.hasPartitioned) ctx.enabledExtensions.push_back(VK_NV_SHADER_SUBGROUP_PARTITIONED_EXTENSION_NAME);
  if (hasExecutableProps && haveExec.pipelineExecutableInfo) {
    wantExec.pipelineExecutableInfo = VK_TRUE;
    append(wantExec);
    ctx.enabledExtensions.push_back(VK_KHR_PIPELINE_EXECUTABLE_PROPERTIES_EXTENSION_NAME);
    ctx.pipelineExecutableInfo = true;
  }
}

void recordCapabilities(Context& ctx, const Supported& s, const Enabled& e) {
  const VkPhysicalDeviceFeatures& h = s.have.features.features;
  const auto& subgroup = s.subgroup;
  const bool atomics64 = e.atomics64;
  const bool extendedTypes = e.extendedTypes;
  const bool hostReset = e.hostReset;
  const bool bda = e.bda;
  const bool indexing = e.indexing;
  ctx.shaderInt64 = h.shaderInt64;
  ctx.int64Atomics = h.shaderInt64 && atomics64;
  ctx.fragmentStoresAndAtomics = h.fragmentStoresAndAtomics;
  ctx.vertexPipelineStoresAndAtomics = h.vertexPipelineStoresAndAtomics;
  ctx.pipelineStatistics = h.pipelineStatisticsQuery;
  ctx.storageImageWriteWithoutFormat = h.shaderStorageImageWriteWithoutFormat;
  ctx.storageImageReadWithoutFormat = h.shaderStorageImageReadWithoutFormat;
  ctx.shaderSubgroupExtendedTypes = extendedTypes;
  ctx.hostQueryReset = hostReset;
  ctx.bufferDeviceAddress = bda;
  ctx.descriptorIndexing = indexing;
  ctx.subgroupSize = subgroup.subgroupSize;
  // Subgroup counting elects a lane (basic), groups lanes by slot (ballot),
  // adds lane counts (arithmetic) and asks whether one reduction holds a
  // flush's sums (vote).
  constexpr VkSubgroupFeatureFlags kNeeded =
      VK_SUBGROUP_FEATURE_BASIC_BIT | VK_SUBGROUP_FEATURE_VOTE_BIT | VK_SUBGROUP_FEATURE_BALLOT_BIT |
      VK_SUBGROUP_FEATURE_ARITHMETIC_BIT;
  ctx.subgroupArithmetic = (subgroup.supportedOperations & kNeeded) == kNeeded;
  ctx.subgroupStages = ctx.subgroupArithmetic ? toStageMask(subgroup.supportedStages) : 0;
  ctx.subgroupPartitionedStages =
      s.hasPartitioned && (subgroup.supportedOperations & VK_SUBGROUP_FEATURE_PARTITIONED_BIT_NV) != 0 ? ctx.subgroupStages
                                                                                                        : 0;
  // Not known to be fixed in a later Mesa: applies to every llvmpipe until checked.
  ctx.volatileHelperInvocationCrashes = ctx.driverID == VK_DRIVER_ID_MESA_LLVMPIPE;
}

}  // namespace tally::gpu
