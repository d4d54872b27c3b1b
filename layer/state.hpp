// The layer's view of one instance and its devices: the objects the
// application created (what counting attributes to), the pipelines it
// instrumented, the command buffers being recorded and the submissions whose
// counters are still being read back. docs/layer.md describes the model.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include <vulkan/vulkan.h>
#include <vulkan/vk_layer.h>
#include <nlohmann/json.hpp>

#include "addresses.hpp"
#include "attribution.hpp"
#include "spirv/instrument.hpp"

namespace tally::layer {

struct DescriptorBufferDevice;  // descriptor_buffers_layer.cpp

// The loader's dispatch table pointer: the same for an instance and its
// physical devices, and for a device, its queues and command buffers.
inline void* dispatchKey(const void* handle) { return *static_cast<void* const*>(handle); }
template <class T>
uint64_t u64(T handle) {
  return reinterpret_cast<uint64_t>(handle);
}

// What the environment asks of the layer (docs/layer.md, "Configuration").
struct Config {
  std::string output;          // TALLY_LAYER_OUTPUT: the result file ("" : none is written)
  uint32_t frames = 10;        // TALLY_LAYER_FRAMES
  uint32_t skipFrames = 0;     // TALLY_LAYER_SKIP_FRAMES
  uint32_t frameSubmits = 0;   // TALLY_LAYER_FRAME_SUBMITS: 0, frames end at present
  spirv::Mode mode{spirv::CountMode::Accumulate};  // TALLY_LAYER_COUNTING
  // TALLY_LAYER_TIMING: the queries around each pass. "all": timestamps and
  // pipeline statistics; "timestamps"; "none": counts only.
  bool timestamps = true, statistics = true;
  // TALLY_LAYER_STATISTICS_FRAMES: the pipeline statistics queries run in
  // command buffers recorded for the window's first N frames only ("all":
  // every frame). On NVIDIA a statistics query around a geometry pass costs
  // as much as the pass (H200 G-buffer 0.27 ms timed, 0.50 ms queried): one
  // frame's statistic checks the counts, every frame's doubles such passes.
  uint32_t statisticsFrames = 1;
  // TALLY_LAYER_COUNTING=off: passes timed (as TALLY_LAYER_TIMING says), the
  // application's own pipelines bound, nothing counted: what the counters
  // cost, per pass, beside a counting run.
  bool counts = true;
  // TALLY_LAYER_SITES=1: counter slots per access site, and each pass's
  // "sites" (bytes per shader source line) in the output.
  bool sites = false;
  // TALLY_LAYER_DRAWS=1 (TALLY_LAYER_SITES=1 turns it on too): a counter
  // region per draw command, and each pass's bytes per draw in the output.
  bool draws = false;
  std::string error;           // a variable that did not parse: the layer counts nothing and says so
  static Config fromEnvironment();
};

struct InstanceState {
  VkInstance instance = VK_NULL_HANDLE;
  PFN_vkGetInstanceProcAddr gipa = nullptr;
  PFN_vkDestroyInstance destroyInstance = nullptr;
  PFN_vkGetPhysicalDeviceProperties getProperties = nullptr;
  PFN_vkGetPhysicalDeviceProperties2 getProperties2 = nullptr;
  PFN_vkGetPhysicalDeviceFeatures getFeatures = nullptr;
  PFN_vkGetPhysicalDeviceFeatures2 getFeatures2 = nullptr;
  PFN_vkGetPhysicalDeviceMemoryProperties getMemoryProperties = nullptr;
  PFN_vkGetPhysicalDeviceQueueFamilyProperties getQueueFamilies = nullptr;
  std::string applicationName, engineName;
  uint32_t apiVersion = VK_API_VERSION_1_0;
};

// The device functions the layer calls down the chain.
struct DeviceDispatch {
#define TALLY_LAYER_DEVICE_FUNCTIONS(X)                                                                       \
  X(GetDeviceProcAddr) X(DestroyDevice) X(GetDeviceQueue) X(GetDeviceQueue2) X(DeviceWaitIdle)                 \
  X(CreateShaderModule) X(DestroyShaderModule) X(CreateGraphicsPipelines) X(CreateComputePipelines)         \
  X(DestroyPipeline) X(CreatePipelineLayout) X(DestroyPipelineLayout) X(CreateDescriptorSetLayout)           \
  X(DestroyDescriptorSetLayout) X(CreateDescriptorPool) X(DestroyDescriptorPool) X(ResetDescriptorPool)      \
  X(AllocateDescriptorSets) X(FreeDescriptorSets) X(UpdateDescriptorSets) X(CreateDescriptorUpdateTemplate)  \
  X(DestroyDescriptorUpdateTemplate) X(UpdateDescriptorSetWithTemplate) X(CreateBuffer) X(DestroyBuffer)    \
  X(CreateBufferView) X(DestroyBufferView) X(CreateImage) X(DestroyImage) X(CreateImageView)                 \
  X(DestroyImageView) X(GetImageMemoryRequirements) X(GetBufferMemoryRequirements) X(AllocateMemory)        \
  X(FreeMemory) X(BindBufferMemory) X(MapMemory) X(UnmapMemory) X(CreateRenderPass) X(CreateRenderPass2)     \
  X(DestroyRenderPass) X(CreateFramebuffer) X(DestroyFramebuffer) X(CreateCommandPool) X(DestroyCommandPool) \
  X(ResetCommandPool) X(AllocateCommandBuffers) X(FreeCommandBuffers) X(BeginCommandBuffer)                  \
  X(EndCommandBuffer) X(ResetCommandBuffer) X(CmdBindPipeline) X(CmdBindDescriptorSets)                      \
  X(CmdBindVertexBuffers) X(CmdBindIndexBuffer) X(CmdDraw) X(CmdDrawIndexed) X(CmdDrawIndirect)             \
  X(CmdDrawIndexedIndirect) X(CmdDrawIndirectCount) X(CmdDrawIndexedIndirectCount) X(CmdDispatch)           \
  X(CmdDispatchIndirect) X(CmdDispatchBase) X(CmdBeginRenderPass) X(CmdNextSubpass) X(CmdEndRenderPass)      \
  X(CmdBeginRenderPass2) X(CmdNextSubpass2) X(CmdEndRenderPass2) X(CmdBeginRendering) X(CmdEndRendering)     \
  X(CmdExecuteCommands) X(CmdPipelineBarrier) X(CmdCopyBuffer) X(CmdFillBuffer) X(CmdWriteTimestamp)         \
  X(CmdResetQueryPool) X(CmdBeginQuery) X(CmdEndQuery) X(CmdCopyQueryPoolResults) X(CreateQueryPool)         \
  X(DestroyQueryPool) X(QueueSubmit) X(QueueSubmit2) X(QueueWaitIdle) X(CreateFence) X(DestroyFence)         \
  X(WaitForFences) X(GetFenceStatus) X(ResetFences) X(CreateSwapchainKHR) X(GetSwapchainImagesKHR)           \
  X(QueuePresentKHR) X(SetDebugUtilsObjectNameEXT) X(CmdBeginDebugUtilsLabelEXT) X(CmdEndDebugUtilsLabelEXT)    \
  X(CmdBindVertexBuffers2) X(CmdDrawMeshTasksEXT) X(CmdDrawMeshTasksIndirectEXT)                              \
  X(CmdDrawMeshTasksIndirectCountEXT) X(CmdDrawMultiEXT) X(CmdDrawMultiIndexedEXT)                          \
  X(CmdPushDescriptorSetKHR) X(CmdPushDescriptorSetWithTemplateKHR) X(CmdSetAlphaToCoverageEnableEXT)
// The dynamic state that decides what draws write and read (dynamic_state.cpp).
#define TALLY_LAYER_DYNAMIC_STATE_FUNCTIONS(X)                                                                \
  X(CmdSetVertexInputEXT) X(CmdSetColorWriteEnableEXT) X(CmdSetColorWriteMaskEXT) X(CmdSetRasterizerDiscardEnable)
#define TALLY_LAYER_MEMBER(name) PFN_vk##name name = nullptr;
  TALLY_LAYER_DEVICE_FUNCTIONS(TALLY_LAYER_MEMBER)
  TALLY_LAYER_DYNAMIC_STATE_FUNCTIONS(TALLY_LAYER_MEMBER)
#undef TALLY_LAYER_MEMBER
};

enum class Kind { Texture, Attachment, Depth, Buffer };
const char* toString(Kind kind);

// An image or buffer the application created (or a swapchain's image).
struct Resource {
  uint64_t handle = 0;
  bool image = false;
  Kind kind = Kind::Buffer;    // from its creation usage; each line's kind comes from its use
  VkImageUsageFlags imageUsage = 0;  // an unnamed image is named by its role, "image" where it has several
  VkFormat format = VK_FORMAT_UNDEFINED;
  uint32_t width = 0, height = 0, samples = 1;
  uint64_t size = 0;             // buffers: VkBufferCreateInfo::size; images: the memory requirement
  std::string usage;
  std::string name;              // debug-utils name, "" for none
  bool destroyed = false;        // by the application; forgotten once no readback can name it (lifetimes.cpp)
  bool counted = false;          // named by a frame of the window: kept for the output's resource list
  std::string displayName() const;  // the name, else kind, handle, format and extent
};

struct ImageView {
  uint64_t image = 0;
  VkFormat format = VK_FORMAT_UNDEFINED;
  VkImageAspectFlags aspect = 0;
};

// What a descriptor element refers to: the resource and, for image views,
// the view's format and aspect (bytes per read).
struct Bound {
  uint64_t resource = 0;
  VkFormat format = VK_FORMAT_UNDEFINED;
  VkImageAspectFlags aspect = 0;
  bool operator==(const Bound&) const = default;
};

struct DescriptorSetState {
  std::map<uint32_t, std::vector<Bound>> bindings;
};

// A pipeline the layer instrumented: its sites, with slots relative to the
// pipeline's region of the counter buffer.
struct PipelineInfo {
  uint64_t handle = 0;  // the application's pipeline, created as it asked
  std::string name;     // vkSetDebugUtilsObjectNameEXT's, "" for none: names its draws
  VkPipeline instrumented = VK_NULL_HANDLE;  // its twin with counters, bound only in command buffers that count
  bool inPlace = false;  // libraries and pipelines linked from them: the application's handle is instrumented
  VkPipelineLayout layout = VK_NULL_HANDLE;
  bool counted = false;
  uint32_t slots = 0;
  std::vector<spirv::Site> sites;
  std::vector<spirv::CopyLayout> foldLayouts;  // settled at readback: striped compute counters folded, derived counts added
  FixedFunction fixed;  // what its draws write, where its vertex attributes come from
  bool hasFragment = false;
  // Graphics pipeline libraries: the parts this pipeline holds
  // (VkGraphicsPipelineLibraryFlagsEXT; all four for a complete pipeline).
  uint32_t libraryParts = 0;
  bool library = false;  // VK_PIPELINE_CREATE_LIBRARY_BIT_KHR: linked into others, never bound
  bool linked = false;   // made from libraries (VkPipelineLibraryCreateInfoKHR)
  // Where alpha to coverage is dynamic, the layer's copy whose fragment
  // shader was given early tests: bound in the application's pipeline's
  // place while alpha to coverage is off (early_tests_twin.hpp).
  VkPipeline earlyTestsTwin = VK_NULL_HANDLE;
  // Shader objects: bytes the counter set is bound before the region, so that
  // the lowest slot band bound lands at its start (shader_objects.hpp).
  VkDeviceSize regionShift = 0;
};

// An indexed indirect draw whose parameters the layer copies, after the
// draw's pass, into its command buffer's indirect buffer (indirect.cpp).
struct IndirectDraw {
  uint32_t pass = 0;
  uint64_t indexBuffer = 0;
  uint32_t indexBytes = 4;
  VkBuffer source = VK_NULL_HANDLE, countSource = VK_NULL_HANDLE;
  VkDeviceSize offset = 0, countOffset = 0;
  uint32_t stride = 0;
  uint32_t maxDraws = 0;      // drawCount, or maxDrawCount with a count buffer
  VkDeviceSize paramsAt = 0;  // maxDraws (indexCount, instanceCount) pairs of 8 bytes
  VkDeviceSize countAt = 0;   // the draw count's 4 bytes, with a count buffer
  bool copied = false;        // its copy is recorded
};

// Region::draw of a dispatch's region, or of any region without
// Config::draws; and of the regions that the draws beyond
// kMaxDrawRegions of one recording share (draw_counts.cpp).
constexpr uint32_t kNoDraw = UINT32_MAX, kRestDraws = UINT32_MAX - 1;
constexpr uint32_t kMaxDrawRegions = 1024;

// Descriptor buffers: where the descriptor a slot reads lies, named at each submission.
struct DescriptorPlace {
  uint32_t slot = 0;
  uint64_t address = 0;
  VkDescriptorType type = VK_DESCRIPTOR_TYPE_MAX_ENUM;
};

// The resource behind each slot of a region, resolved at the draw.
struct Region {
  VkDeviceSize offset = 0;
  VkDeviceSize bytes = 0;
  std::shared_ptr<PipelineInfo> pipeline;
  std::vector<Bound> slotResources;  // per slot: what it counts
  std::vector<DescriptorPlace> descriptorAt;
  uint32_t pass = 0;                 // index into the command buffer's passes
  // Config::draws: the draw command's place in its pass (kRestDraws: shared
  // by the draws beyond the cap, `drawCommands` of them), and the innermost
  // debug label open at it.
  uint32_t draw = kNoDraw;
  uint32_t drawCommands = 0;
  std::string label;
};

// A stretch of the counter arena: a recording's chunk, or what one readback
// copies and zeroes at once.
struct ArenaRange {
  VkDeviceSize offset = 0, bytes = 0;
  VkDeviceSize at = 0;  // in a readback: where the range lies in the harvest's buffer
};

// A render pass instance, a dynamic-rendering scope, or the compute
// dispatches between them.
struct PassScope {
  std::string label;   // the innermost debug label open where it began
  std::string kind;    // "render pass", "rendering", "compute"
  int continues = -1;  // a later subpass: the scope of the render pass's first subpass (its name when unlabelled)
  uint32_t timestampBegin = UINT32_MAX;  // query index; end is begin + 1
  std::vector<uint32_t> statisticQueries;
  uint32_t draws = 0, dispatches = 0;
  std::map<std::pair<uint64_t, uint32_t>, uint64_t> indexReads;  // (index buffer, index bytes) -> indices
  uint32_t views = 1;  // its timestamps' query indices each (multiview: one per view)
};

struct CommandBufferState {
  VkCommandBuffer handle = VK_NULL_HANDLE;
  VkCommandPool pool = VK_NULL_HANDLE;
  bool secondary = false;
  bool graphicsOrCompute = true;
  bool timestamps = false;
  // Recorded for counting (window.cpp, recordForCounting): instrumented
  // pipelines, the counter set, queries. Otherwise the application's own
  // pipelines and nothing of the layer's.
  bool counted = false;
  bool statistics = false;  // this recording queries pipeline statistics (Config::statisticsFrames)
  uint32_t drawCommands = 0;  // draw commands recorded (a secondary's draws are numbered by it)
  uint32_t drawRegions = 0;   // Config::draws: regions of one draw each, at most kMaxDrawRegions
  bool work = false;  // a draw, a dispatch, a render pass or secondaries recorded (a frame's work)
  bool uncountedSecondaries = false;  // executes secondaries with work recorded outside the window
  uint32_t recordings = 0;            // vkBeginCommandBuffer calls so far
  uint32_t submitsOfRecording = 0;    // submissions of the current recording
  bool resubmitted = false;           // some recording was submitted more than once
  std::vector<PassScope> passes;
  std::vector<Region> regions;
  std::map<std::tuple<uint32_t, uint64_t, std::vector<uint64_t>>, size_t> regionIndex;
  // The arena chunks this recording's regions are cut from, one after the
  // other, so that its readback copies and zeroes a few ranges, not a region
  // at a time (a fill per draw cost the GPU about a microsecond each).
  std::vector<ArenaRange> chunks;
  VkDeviceSize chunkNext = 0, chunkEnd = 0;
  VkQueryPool timestampPool = VK_NULL_HANDLE, statisticsPool = VK_NULL_HANDLE;
  uint32_t timestampsUsed = 0, statisticsUsed = 0;
  // recording state
  int currentPass = -1;
  bool inRenderPass = false;
  bool openStatistic = false;
  bool appStatisticsActive = false;
  uint32_t views = 1;  // of the current subpass or rendering scope: a query inside takes one index per view
  bool secondaryContents = false;  // the current subpass or scope records only vkCmdExecuteCommands: no queries inside
  bool suspending = false;         // the current rendering scope suspends: its end timestamp waits for the resume
  int owedEnd = -1;                // a scope whose end timestamp is not written yet
  std::vector<std::string> labels;
  std::vector<Bound> colorAttachments;  // of the current subpass, by Location
  DynamicState dynamic;
  // render pass instance: its attachments and each subpass's colour references
  std::vector<Bound> passAttachments;
  std::vector<std::vector<uint32_t>> subpassColors;
  std::vector<uint32_t> subpassViewMasks;  // multiview: each subpass's
  uint32_t subpass = 0;
  struct BindPoint {
    std::shared_ptr<PipelineInfo> pipeline;
    std::array<uint64_t, 32> sets{};
    VkDeviceSize boundOffset = ~VkDeviceSize(0);
    bool dirty = true;
    std::map<uint32_t, DescriptorSetState> pushed;  // push descriptor sets, by set number
  };
  std::array<BindPoint, 2> bind;  // graphics, compute
  std::array<uint64_t, 8> shaders{};  // vkCmdBindShadersEXT: each stage's shader object (shader_objects.hpp)
  std::map<uint32_t, uint64_t> vertexBuffers;
  uint64_t indexBuffer = 0;
  uint32_t indexBytes = 4;
  bool overflowNoted = false;
  bool renderingSuspends = false;   // the current rendering scope has VK_RENDERING_SUSPENDING_BIT
  bool renderingSuspended = false;  // the last one ended so: nothing may be recorded until it resumes
  std::vector<IndirectDraw> indirectDraws;
  VkBuffer indirectBuffer = VK_NULL_HANDLE;  // where indirect parameters are copied (indirect.cpp)
  VkDeviceMemory indirectMemory = VK_NULL_HANDLE;
  VkDeviceSize indirectUsed = 0;
  struct Coverage {
    bool known = false;                    // vkCmdSetAlphaToCoverageEnableEXT was recorded
    bool alphaToCoverage = false;          // its last value
    VkPipeline pipeline = VK_NULL_HANDLE;  // the graphics pipeline the application bound
    bool twinBound = false;                // its late-tests twin is bound in its place
  } coverage;
};

// One vkQueueSubmit's counters and queries, copied into a host-visible
// buffer by a command buffer the layer submits right after it.
struct Harvest {
  uint64_t frame = 0;
  uint64_t serial = 0;  // in submission order
  VkFence fence = VK_NULL_HANDLE;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  VkCommandPool pool = VK_NULL_HANDLE;
  VkBuffer buffer = VK_NULL_HANDLE;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  void* mapped = nullptr;
  struct Part {
    std::vector<PassScope> passes;
    std::vector<Region> regions;
    std::vector<VkDeviceSize> regionAt;  // where each region's counters lie in the buffer
    std::vector<ArenaRange> ranges;      // the regions' arena, merged where adjacent: copied and zeroed
    VkDeviceSize timestampsAt = 0, statisticsAt = 0;
    uint32_t timestamps = 0, statistics = 0;
    std::vector<IndirectDraw> indirectDraws;  // copied ones only
    VkDeviceSize indirectAt = 0;              // where the command buffer's indirect buffer lies
  };
  std::vector<Part> parts;  // one per command buffer submitted
  std::vector<VkQueryPool> queryPools;  // the submitted command buffers' pools its copies read
  std::vector<VkBuffer> indirectBuffers;  // and their indirect-parameter copies
};

// A frame's passes as read back, before they are written out.
struct PassRecord {
  std::string name;
  int joins = -1;  // a later subpass without a label of its own: the frame's pass of its first subpass
  double gpuMs = 0;
  bool timed = false;
  uint32_t draws = 0, dispatches = 0;
  uint64_t fragmentInvocations = 0, vertexInvocations = 0, computeInvocations = 0;
  int64_t fragmentStatistic = -1, computeStatistic = -1, vertexStatistic = -1;
  struct Line {
    uint64_t count = 0, bytes = 0;
    std::string kind, format;
  };
  std::map<std::tuple<std::string, bool, std::string>, Line> lines;  // (resource name, write, source)
  // Config::sites: each site's share of the counted lines.
  struct SiteLine {
    spirv::Site site;
    std::string kind;
    uint64_t count = 0, bytes = 0;
  };
  // (shader, instruction, resource name, write)
  std::map<std::tuple<std::string, uint32_t, std::string, bool>, SiteLine> sites;
  // Config::draws: each draw command's share of the counted lines, by its
  // place in the pass; `drawsRest` those beyond kMaxDrawRegions.
  struct DrawLine {
    std::string label, pipeline;
    uint32_t commands = 0;
    uint64_t count = 0, bytesRead = 0, bytesWritten = 0;
  };
  std::map<uint32_t, DrawLine> drawLines;
  DrawLine drawsRest;
};
struct FrameRecord {
  uint64_t index = 0;
  uint32_t submissions = 0;
  std::vector<PassRecord> passes;
  uint32_t pendingHarvests = 0;
  bool closed = false;
  bool leftOut = false;  // ran a command buffer recorded outside the window: not written, the window grows by one
  bool done() const { return closed && pendingHarvests == 0 && !leftOut; }  // read whole: written to the output
};

struct ShaderInfo {
  std::vector<uint32_t> words;
  std::string name;
};

struct ShaderObjects;  // shader_objects.hpp

struct DeviceState {
  VkDevice device = VK_NULL_HANDLE;
  VkPhysicalDevice physical = VK_NULL_HANDLE;
  InstanceState* instance = nullptr;
  DeviceDispatch d;
  PFN_vkSetDeviceLoaderData setLoaderData = nullptr;
  VkPhysicalDeviceProperties properties{};
  VkPhysicalDeviceMemoryProperties memory{};
  std::vector<VkQueueFamilyProperties> families;
  bool fragmentStores = false, vertexStores = false, statistics = false;
  bool int64Atomics = false;  // shaderInt64 and shaderBufferInt64Atomics enabled: 64-bit counters
  std::string driverInfo;
  bool llvmpipe = false;  // Mesa's lavapipe (see instrumentStages)
  Config config;
  uint32_t index = 0;  // the process's devices in creation order; device N > 0 writes <output>.deviceN

  std::mutex mutex;
  // Counting: off when the device cannot (the reason says why).
  bool counting = false;
  std::string notCounting;
  uint32_t counterSet = 7;
  spirv::InstrumentOptions instrumentOptions;
  VkDescriptorSetLayout counterSetLayout = VK_NULL_HANDLE, emptySetLayout = VK_NULL_HANDLE;
  VkDescriptorPool descriptorPool = VK_NULL_HANDLE;
  VkDescriptorSet counterDescriptorSet = VK_NULL_HANDLE;
  VkBuffer counterBuffer = VK_NULL_HANDLE;
  VkDeviceMemory counterMemory = VK_NULL_HANDLE;
  VkDeviceSize arenaBytes = 0, regionRange = 0, alignment = 256, arenaNext = 0;
  std::map<VkDeviceSize, std::vector<VkDeviceSize>> freeRegions;  // size -> offsets

  // What the application created.
  std::unordered_map<uint64_t, ShaderInfo> shaders;
  std::set<uint64_t> descriptorBufferLayouts;  // set layouts made for descriptor buffers (uncounted.cpp)
  std::shared_ptr<DescriptorBufferDevice> descriptorBuffers;  // descriptor_buffers_layer.hpp
  std::set<uint64_t> countedLayouts;  // pipeline layouts extended with the counter set (the handles the application holds)
  // Independent-sets layouts (null between the application's sets and the
  // counter set) -> their twin with empty sets there, for complete pipelines.
  std::unordered_map<uint64_t, VkPipelineLayout> completeLayouts;
  std::unordered_map<uint64_t, std::shared_ptr<PipelineInfo>> pipelines;
  std::unordered_map<uint64_t, DescriptorSetState> sets;
  std::unordered_map<uint64_t, std::set<uint64_t>> poolSets;
  std::unordered_map<uint64_t, std::vector<VkDescriptorUpdateTemplateEntry>> templates;
  std::unordered_map<uint64_t, std::pair<VkPipelineBindPoint, std::vector<VkDescriptorUpdateTemplateEntry>>>
      pushTemplates;  // templates of push descriptors: their bind point and entries
  std::unordered_map<uint64_t, std::shared_ptr<PipelineInfo>> libraries;  // graphics pipeline libraries
  std::shared_ptr<ShaderObjects> shaderObjects;  // VK_EXT_shader_object, from the first vkCreateShadersEXT
  std::unordered_map<uint64_t, Resource> resources;  // destroyed ones stay: their counts may still be read back
  std::unordered_map<uint64_t, ImageView> views;
  std::unordered_map<uint64_t, uint64_t> bufferViews;  // view -> buffer
  std::unordered_map<uint64_t, std::vector<std::vector<uint32_t>>> renderPasses;  // subpass -> colour attachment indices
  std::unordered_map<uint64_t, std::vector<uint64_t>> framebuffers;  // attachment views
  std::unordered_map<uint64_t, std::vector<uint32_t>> subpassViewMasks;  // render passes with multiview: per subpass
  std::unordered_map<uint64_t, uint32_t> poolFamilies;  // command pool -> queue family
  std::unordered_map<VkCommandBuffer, std::unique_ptr<CommandBufferState>> commandBuffers;
  AddressBook addresses;  // buffer device addresses (addresses.hpp)
  std::unordered_map<VkQueue, uint32_t> queueFamilies;
  std::unordered_map<uint64_t, std::pair<VkFormat, VkExtent2D>> swapchains;
  VkExtent2D extent{0, 0};

  // The layer's own command pools (one per queue family) and readback.
  std::map<uint32_t, VkCommandPool> ownPools;
  std::deque<std::unique_ptr<Harvest>> pending;
  std::vector<std::unique_ptr<Harvest>> idle;
  // Query pools of freed command buffers, for later recordings: creating two
  // per command buffer cost an application that allocates one a frame more
  // than all the counting. A pool a pending readback still copies from waits
  // in `retiringPools` (true: statistics) until that readback is read.
  std::vector<VkQueryPool> freeTimestampPools, freeStatisticsPools;
  std::vector<std::pair<VkQueryPool, bool>> retiringPools;
  uint64_t nextHarvest = 0;  // the serial of the next readback
  std::map<uint64_t, uint64_t> retired;  // destroyed resource -> the first readback that cannot name it

  // Frames.
  uint64_t frame = 0;            // the application's current frame
  uint32_t frameWorkSubmits = 0;  // submissions with draws or dispatches in this frame
  std::map<uint64_t, FrameRecord> frames;
  uint32_t framesLeftOut = 0;     // frames of the window that ran uncounted work: each extends it by one
  uint32_t framesDone = 0;        // frames whose done() holds, kept by changeFrame
  uint64_t readbacksRiding = 0;   // readbacks submitted in the application's own submission (QueueSubmit)
  uint64_t readbackWaits = 0;     // blocking waits for a readback before the end (ring full, indirect buffer freed)
  uint64_t queryPoolsCreated = 0;  // the rest of the command buffers' pools are used again
  double pipelineMsApplication = 0, pipelineMsInstrumented = 0;  // creation time: the application's, the twins'
  bool written = false;
  std::vector<nlohmann::json> shaderReports;
  uint32_t pipelinesCreated = 0, pipelinesCounted = 0, layoutsRefused = 0;
  uint32_t librariesCreated = 0, pipelinesLinked = 0;  // graphics pipeline libraries; pipelines linked from them
  std::set<std::string> notes;
};

// layer.cpp: the state behind a dispatchable handle (null for one the layer
// never saw), and a command buffer's recording state (null likewise).
DeviceState* deviceOf(const void* handle);
CommandBufferState* commandBufferOf(DeviceState& dev, VkCommandBuffer cb);

// counters.cpp: the counter buffer, its regions, and the counter set bound at each draw.
void setupCounting(DeviceState& dev);
void destroyCounting(DeviceState& dev);
// Finds (or allocates) the region of this draw and binds the counter set at it.
// `draw`: the draw command's place in its pass (Config::draws), else kNoDraw.
void beforeDraw(DeviceState& dev, CommandBufferState& cb, uint32_t bindPointIndex, bool isDispatch,
                uint32_t draw = kNoDraw);
void releaseRegions(DeviceState& dev, CommandBufferState& cb);

// readback.cpp: readbacks after submissions, frames, the output file.
void afterSubmit(DeviceState& dev, VkQueue queue, const std::vector<VkCommandBuffer>& submitted);
// afterSubmit in two steps, for a readback that rides in the application's
// own submission (layer.cpp, QueueSubmit): prepareSubmit records it (after
// the bookkeeping of the submitted command buffers); finishSubmit takes the
// result of the submission it rode in, or VK_NOT_READY to submit it alone.
struct PreparedSubmit {
  Harvest* readback = nullptr;  // recorded, not yet submitted
  bool work = false;            // the submission drew or dispatched
};
PreparedSubmit prepareSubmit(DeviceState& dev, VkQueue queue, const std::vector<VkCommandBuffer>& submitted);
void finishSubmit(DeviceState& dev, VkQueue queue, const PreparedSubmit& prepared, VkResult rodeAlong);
void afterIdle(DeviceState& dev);  // the device or a queue is idle: reads what arrived
void endFrame(DeviceState& dev);
void finish(DeviceState& dev, bool complete);  // waits for every harvest and writes the output
// Hands the command buffer's query pools back for later recordings (after the readbacks that copy them).
void retireQueryPools(DeviceState& dev, CommandBufferState& cb);
VkQueryPool takeQueryPool(DeviceState& dev, bool statistics);
void waitForIndirectReadbacks(DeviceState& dev, const CommandBufferState& cb);

// harvest.cpp: a finished readback's counters and queries into its frames' passes.
void processHarvest(DeviceState& dev, Harvest& h);

// output.cpp
nlohmann::json outputJson(DeviceState& dev, bool complete);

// draw_counts.cpp: Config::draws, a pass's bytes per draw command.
// A region read back: its draw listed (with no bytes yet), or its draw
// commands added to the rest.
void noteDraw(const DeviceState& dev, const Region& region, PassRecord& pass);
// Adds one counted line's share of a region to its draw (or to the rest).
void addDrawCount(const DeviceState& dev, const Region& region, bool write, uint64_t count, uint64_t bytes,
                  PassRecord& pass);
// A later subpass's draws into its first's, numbered after the `before` draws it had.
void joinDraws(PassRecord& into, const PassRecord& p, uint32_t before);
// The pass's "draw_list" (the kMaxDrawsListed with the most bytes) and "draws_rest" (null: none).
nlohmann::json drawListJson(const PassRecord& pass);
nlohmann::json drawsRestJson(const PassRecord& pass);

void log(const std::string& line);  // layer.cpp: a line on stderr

// indirect.cpp: index reads of indexed indirect draws, from their parameters read back.
void noteIndexedIndirect(DeviceState& dev, CommandBufferState& cb, VkBuffer buffer, VkDeviceSize offset,
                         uint32_t maxDraws, uint32_t stride, VkBuffer countBuffer, VkDeviceSize countOffset);
// Records the copies of the draws' parameters where commands may be recorded
// (outside a render pass or a suspended rendering scope); `end`: the command
// buffer ends, and a note says what could not be copied.
void recordIndirectCopies(DeviceState& dev, CommandBufferState& cb, bool end);
void destroyIndirect(DeviceState& dev, CommandBufferState& cb);
void addIndirectReads(Harvest::Part& part, const uint8_t* base);  // into the parts' passes' indexReads

// window.cpp: which command buffers count, and the frames of the window.
constexpr uint32_t kDrainOnly = UINT32_MAX;  // Region::pass of a region read only to zero it
bool windowAhead(const DeviceState& dev);    // an output is wanted and frames are still to be read
bool inWindow(const DeviceState& dev, uint64_t frame);
bool recordForCounting(DeviceState& dev, CommandBufferState& cb, VkCommandBufferUsageFlags flags);
void assignOutput(DeviceState& dev);  // the device's index and output path
uint32_t framesCounted(const DeviceState& dev);
// Every change to a frame's closed, pendingHarvests or leftOut goes through
// here, so that the count of frames done is kept as they change: the window's
// end is checked after every frame, and counting the frames anew each time
// made a frame's end cost grow with the frames already counted (a 2,000-frame
// window of a 0.2 ms frame doubled its frame time).
template <class Change>
void changeFrame(DeviceState& dev, FrameRecord& frame, Change&& change) {
  bool before = frame.done();
  change(frame);
  dev.framesDone = dev.framesDone - (before ? 1 : 0) + (frame.done() ? 1 : 0);
}

// lifetimes.cpp: what the layer forgets of objects the application destroyed.
void retireResource(DeviceState& dev, uint64_t handle);
void forgetRetired(DeviceState& dev);  // after readbacks: resources no pending readback names

// twins.cpp: each instrumented pipeline beside the application's own.
void createGraphicsTwins(DeviceState& dev, const std::vector<VkGraphicsPipelineCreateInfo>& patched,
                         const std::vector<std::shared_ptr<PipelineInfo>>& states);
void createComputeTwins(DeviceState& dev, const std::vector<VkComputePipelineCreateInfo>& patched,
                        const std::vector<std::shared_ptr<PipelineInfo>>& states);

}  // namespace tally::layer
