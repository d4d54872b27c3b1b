#include "gpu/ceilings.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <vector>

#include "gpu/pipelines.hpp"
#include "gpu/queries.hpp"
#include "gpu/resources.hpp"
#include "gpu/shaders.hpp"
#include "gpu/vk_check.hpp"

namespace tally::gpu {
namespace {

constexpr uint64_t kMiB = 1024ull * 1024;
constexpr uint32_t kGroupSize = 256;       // local_size_x of both kernels
constexpr uint32_t kOpsPerIteration = 64;  // ceiling_fma: 8 chains x 4 components x 2 (multiply, add)
// Target time of one arithmetic run: long against the timestamp resolution
// and launch cost, short enough that five of them stay well under a second
// on lavapipe.
constexpr double kArithmeticTargetS = 0.02;
constexpr uint32_t kMinIterations = 16, kMaxIterations = 1u << 20;
constexpr uint32_t kCopyPerInvocation = 4;  // ceiling_copy's kPerInvocation
// The copy's source holds this word everywhere and its destination starts at
// zero, so a copy that skipped or misplaced elements shows in the readback.
constexpr uint32_t kCopyPattern = 0x7A11C0DEu;
constexpr uint64_t kCopyCheckWindow = 64 * 1024;  // bytes read back at the start, middle and end

bool isCpu(const Context& ctx) { return ctx.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU; }

struct Kernel {
  VkDescriptorSetLayout setLayout = VK_NULL_HANDLE;
  VkPipelineLayout layout = VK_NULL_HANDLE;
  VkShaderModule module = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
};

// Everything the measurement creates, destroyed whatever happens.
struct Objects {
  const Context& ctx;
  Kernel copy, fma;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  Buffer source, destination, result;
  TimestampQueries queries;
  explicit Objects(const Context& c) : ctx(c) {}
  ~Objects() {
    vkDeviceWaitIdle(ctx.device);
    for (Kernel* k : {&copy, &fma}) {
      if (k->pipeline != VK_NULL_HANDLE) vkDestroyPipeline(ctx.device, k->pipeline, nullptr);
      if (k->layout != VK_NULL_HANDLE) vkDestroyPipelineLayout(ctx.device, k->layout, nullptr);
      if (k->setLayout != VK_NULL_HANDLE) vkDestroyDescriptorSetLayout(ctx.device, k->setLayout, nullptr);
      destroyShaderModule(ctx, k->module);
    }
    if (pool != VK_NULL_HANDLE) vkDestroyDescriptorPool(ctx.device, pool, nullptr);
    for (Buffer* b : {&source, &destination, &result}) destroyBuffer(ctx, *b);
    destroyTimestampQueries(ctx, queries);
  }
};

Result<bool> makeKernel(const Context& ctx, const std::string& dir, const std::string& file, uint32_t buffers,
                        uint32_t pushBytes, Kernel& kernel) {
  auto source = loadShaderSource(ctx, dir, file);
  if (!source) return makeError(source.error());
  auto compiled = compileShader(*source);
  if (!compiled) return makeError(compiled.error());
  std::vector<VkDescriptorSetLayoutBinding> bindings;
  for (uint32_t b = 0; b < buffers; ++b) {
    bindings.push_back({b, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr});
  }
  kernel.setLayout = createDescriptorSetLayout(ctx, bindings);
  kernel.layout = createPipelineLayout(ctx, {&kernel.setLayout, 1}, pushBytes, VK_SHADER_STAGE_COMPUTE_BIT);
  kernel.module = createShaderModule(ctx, compiled->words);
  kernel.pipeline = createComputePipeline(ctx, kernel.module, kernel.layout);
  return true;
}

VkDescriptorSet bindBuffers(const Context& ctx, VkDescriptorPool pool, const Kernel& kernel,
                            std::initializer_list<const Buffer*> buffers) {
  VkDescriptorSet set = allocateDescriptorSet(ctx, pool, kernel.setLayout);
  std::vector<DescriptorWrite> writes;
  uint32_t binding = 0;
  for (const Buffer* b : buffers) {
    DescriptorWrite w;
    w.binding = binding++;
    w.buffer = {b->buffer, 0, VK_WHOLE_SIZE};
    writes.push_back(w);
  }
  updateDescriptorSet(ctx, set, writes);
  return set;
}

// Seconds of each of `runs` recordings of `dispatch`, one after another (a
// barrier between them: each starts when the last has finished). Timestamps
// where the queue writes them, else host time around one submission each.
std::vector<double> timeRuns(const Context& ctx, TimestampQueries& queries, uint32_t runs,
                             const std::function<void(VkCommandBuffer)>& dispatch) {
  auto barrier = [](VkCommandBuffer cmd) {
    VkMemoryBarrier b = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
    b.srcAccessMask = VK_ACCESS_SHADER_WRITE_BIT;
    b.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, 0, 1, &b,
                         0, nullptr, 0, nullptr);
  };
  std::vector<double> seconds;
  if (ctx.timestamps) {
    if (queries.passCount != runs) {  // every query of the pool is read back: exactly `runs` pairs
      destroyTimestampQueries(ctx, queries);
      queries = createTimestampQueries(ctx, runs);
    }
    submitAndWait(ctx, [&](VkCommandBuffer cmd) {
      resetTimestamps(cmd, queries);
      for (uint32_t r = 0; r < runs; ++r) {
        writePassBegin(cmd, queries, r);
        dispatch(cmd);
        writePassEnd(cmd, queries, r);
        barrier(cmd);
      }
    });
    auto ms = readPassTimesMs(ctx, queries);
    for (uint32_t r = 0; r < runs; ++r) seconds.push_back(ms[r] * 1e-3);
    return seconds;
  }
  for (uint32_t r = 0; r < runs; ++r) {
    auto started = std::chrono::steady_clock::now();
    submitAndWait(ctx, dispatch);
    seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  }
  return seconds;
}

double fastest(const std::vector<double>& seconds) {
  double best = std::numeric_limits<double>::infinity();
  for (double s : seconds) {
    if (s > 0) best = std::min(best, s);
  }
  return std::isinf(best) ? 0.0 : best;
}

}  // namespace

uint64_t copyBytesFor(const Context& ctx) {
  uint64_t bytes = 256 * kMiB;
  if (ctx.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU) bytes = 128 * kMiB;
  if (isCpu(ctx)) bytes = 64 * kMiB;
  uint64_t heap = 0;
  for (uint32_t i = 0; i < ctx.memoryProperties.memoryHeapCount; ++i) {
    const auto& h = ctx.memoryProperties.memoryHeaps[i];
    if (h.flags & VK_MEMORY_HEAP_DEVICE_LOCAL_BIT) heap = std::max<uint64_t>(heap, h.size);
  }
  if (heap > 0) bytes = std::min(bytes, heap / 8);
  bytes = std::min<uint64_t>(bytes, ctx.limits.maxStorageBufferRange);
  return std::max<uint64_t>(bytes / 16 * 16, 16);
}

Result<Ceilings> measureCeilings(const Context& ctx, const std::string& shaderDir, const CeilingOptions& options) {
  const auto started = std::chrono::steady_clock::now();
  Ceilings out;
  out.repetitions = std::max(options.repetitions, 1u);
  out.timing = ctx.timestamps ? "timestamps" : "host";
  out.copyBytes = options.copyBytes > 0 ? options.copyBytes / 16 * 16 : copyBytesFor(ctx);
  if (out.copyBytes == 0) return makeError("ceilings: copy size must be at least 16 bytes");
  try {
    Objects o(ctx);
    if (auto ok = makeKernel(ctx, shaderDir, "ceiling_copy.comp.glsl", 2, 2 * sizeof(uint32_t), o.copy); !ok) {
      return makeError("ceilings: " + ok.error());
    }
    if (auto ok = makeKernel(ctx, shaderDir, "ceiling_fma.comp.glsl", 1, 3 * sizeof(uint32_t), o.fma); !ok) {
      return makeError("ceilings: " + ok.error());
    }
    VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 3}};
    o.pool = createDescriptorPool(ctx, 2, sizes);

    // Bandwidth: one warm-up copy (first touch of the pages, caches of the
    // code), then the timed ones.
    const VkBufferUsageFlags storage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    o.source = createBuffer(ctx, out.copyBytes, storage, MemoryUse::DeviceLocal);
    o.destination = createBuffer(ctx, out.copyBytes, storage, MemoryUse::DeviceLocal);
    fillBuffer(ctx, o.source, kCopyPattern);
    zeroBuffer(ctx, o.destination);
    VkDescriptorSet copySet = bindBuffers(ctx, o.pool, o.copy, {&o.source, &o.destination});
    const uint32_t elements = static_cast<uint32_t>(std::min<uint64_t>(out.copyBytes / 16, UINT32_MAX));
    // kCopyPerInvocation elements per invocation, a dispatch's width apart;
    // rows of at most 4096 workgroups (within every device's
    // maxComputeWorkGroupCount), as many rows as it takes.
    const uint32_t invocations = (elements + kCopyPerInvocation - 1) / kCopyPerInvocation;
    const uint32_t groups = (invocations + kGroupSize - 1) / kGroupSize;
    const uint32_t copyGroupsX = std::min<uint32_t>(groups, std::min(4096u, ctx.limits.maxComputeWorkGroupCount[0]));
    const uint32_t copyGroupsY = (groups + copyGroupsX - 1) / copyGroupsX;
    if (copyGroupsY > ctx.limits.maxComputeWorkGroupCount[1]) return makeError("ceilings: copy too large for one dispatch");
    const struct {
      uint32_t elements, stride;
    } copyPush = {elements, copyGroupsX * copyGroupsY * kGroupSize};
    out.copyInvocations = copyGroupsX * copyGroupsY * kGroupSize;
    auto copy = [&](VkCommandBuffer cmd) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, o.copy.pipeline);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, o.copy.layout, 0, 1, &copySet, 0, nullptr);
      vkCmdPushConstants(cmd, o.copy.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof copyPush, &copyPush);
      vkCmdDispatch(cmd, copyGroupsX, copyGroupsY, 1);
    };
    auto copyTimes = timeRuns(ctx, o.queries, out.repetitions + 1, copy);
    copyTimes.erase(copyTimes.begin());
    out.copySeconds = fastest(copyTimes);
    if (out.copySeconds <= 0) return makeError("ceilings: the copy took no measurable time");
    out.bandwidthBytesPerS = 2.0 * double(out.copyBytes) / out.copySeconds;
    // The copy must have written what it read: windows at the start, the
    // middle and the end of the destination (the whole of a small one).
    const uint64_t window = std::min(kCopyCheckWindow, out.copyBytes);
    for (uint64_t offset : {uint64_t(0), (out.copyBytes - window) / 2 / 16 * 16, out.copyBytes - window}) {
      auto bytes = readBuffer(ctx, o.destination, offset, window);
      for (size_t i = 0; i + sizeof(uint32_t) <= bytes.size(); i += sizeof(uint32_t)) {
        uint32_t word;
        std::memcpy(&word, bytes.data() + i, sizeof word);
        if (word != kCopyPattern) {
          char text[128];
          std::snprintf(text, sizeof text, "ceilings: the copy wrote 0x%08x at byte %llu, not 0x%08x", word,
                        static_cast<unsigned long long>(offset + i), kCopyPattern);
          return makeError(text);
        }
      }
      out.copyVerifiedBytes += bytes.size();
    }
    destroyBuffer(ctx, o.source);
    destroyBuffer(ctx, o.destination);

    // Arithmetic: enough invocations to fill the device; the iteration count
    // from a short first run, scaled to about kArithmeticTargetS.
    const uint32_t fmaGroups = isCpu(ctx) ? 64 : 4096;
    out.fmaInvocations = fmaGroups * kGroupSize;
    o.result = createBuffer(ctx, VkDeviceSize(out.fmaInvocations) * 16, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                            MemoryUse::DeviceLocal);
    VkDescriptorSet fmaSet = bindBuffers(ctx, o.pool, o.fma, {&o.result});
    struct {
      uint32_t iterations;
      float multiplier, addend;
    } push = {isCpu(ctx) ? 32u : 256u, 0.999f, 0.001f};
    auto fma = [&](VkCommandBuffer cmd) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, o.fma.pipeline);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, o.fma.layout, 0, 1, &fmaSet, 0, nullptr);
      vkCmdPushConstants(cmd, o.fma.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof push, &push);
      vkCmdDispatch(cmd, fmaGroups, 1, 1);
    };
    auto probe = timeRuns(ctx, o.queries, 2, fma);  // the first warms up
    double probeSeconds = fastest({probe.back()});
    if (probeSeconds > 0) {
      double scaled = double(push.iterations) * kArithmeticTargetS / probeSeconds;
      push.iterations = static_cast<uint32_t>(std::clamp(scaled, double(kMinIterations), double(kMaxIterations)));
    }
    out.fmaIterations = push.iterations;
    out.arithmeticOps = uint64_t(out.fmaInvocations) * out.fmaIterations * kOpsPerIteration;
    out.arithmeticSeconds = fastest(timeRuns(ctx, o.queries, out.repetitions, fma));
    if (out.arithmeticSeconds <= 0) return makeError("ceilings: the arithmetic kernel took no measurable time");
    out.arithmeticOpsPerS = double(out.arithmeticOps) / out.arithmeticSeconds;
  } catch (const std::exception& e) {
    return makeError(std::string("ceilings: ") + e.what());
  }
  out.measureSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return out;
}

nlohmann::json toJson(const Ceilings& c) {
  return {
      {"bandwidth_bytes_per_s", c.bandwidthBytesPerS},
      {"arithmetic_ops_per_s", c.arithmeticOpsPerS},
      // Where a pass's intensity (ops per byte) meets both ceilings.
      {"ridge_intensity", c.bandwidthBytesPerS > 0 ? c.arithmeticOpsPerS / c.bandwidthBytesPerS : 0.0},
      {"copy_bytes", c.copyBytes},
      {"method",
       {{"bandwidth", "compute copy of copy_bytes into a second buffer, 16 bytes per element, 4 elements per invocation; "
                      "bytes = read + written; the fastest of the repetitions after one warm-up"},
        {"arithmetic", "8 independent vec4 multiply-add chains per invocation; 2 ops per multiply-add per "
                       "component; the fastest of the repetitions"},
        {"timing", c.timing},
        {"repetitions", c.repetitions},
        {"copy_seconds", c.copySeconds},
        {"copy_invocations", c.copyInvocations},
        {"copy_verified_bytes", c.copyVerifiedBytes},
        {"arithmetic_ops", c.arithmeticOps},
        {"arithmetic_seconds", c.arithmeticSeconds},
        {"arithmetic_invocations", c.fmaInvocations},
        {"arithmetic_iterations", c.fmaIterations},
        {"seconds", c.measureSeconds}}},
  };
}

}  // namespace tally::gpu
