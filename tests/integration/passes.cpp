#include "passes.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <functional>
#include <stdexcept>

#include "gpu/vk_check.hpp"
#include "gpu_fixture.hpp"

namespace tally::test {
namespace {

constexpr VkFormat kColorFormat = VK_FORMAT_R8G8B8A8_UNORM;
constexpr uint32_t kTextureSize = 16;  // the small sampled textures, 16x16 texels

// Runs the cleanup at scope exit, also when a VK_CHECK throws.
class Defer {
 public:
  explicit Defer(std::function<void()> fn) : fn_(std::move(fn)) {}
  ~Defer() { fn_(); }
  Defer(const Defer&) = delete;
  Defer& operator=(const Defer&) = delete;

 private:
  std::function<void()> fn_;
};

// A recognisable, non-constant pattern per texture.
std::vector<uint8_t> pattern(uint32_t width, uint32_t height, uint32_t seed) {
  std::vector<uint8_t> texels(size_t(width) * height * 4);
  for (uint32_t y = 0; y < height; ++y) {
    for (uint32_t x = 0; x < width; ++x) {
      uint8_t* t = &texels[(size_t(y) * width + x) * 4];
      t[0] = static_cast<uint8_t>(x * 16 + seed * 50);
      t[1] = static_cast<uint8_t>(y * 16 + seed * 20);
      t[2] = static_cast<uint8_t>(((x ^ y) * 16) + seed);
      t[3] = 255;
    }
  }
  return texels;
}

Result<std::vector<uint32_t>> compileFile(const gpu::Context& ctx, const std::string& name,
                                          std::optional<glsl::Target> target) {
  auto source = gpu::loadShaderSource(ctx, shaderDir(), name);
  if (!source) return makeError(source.error());
  if (target) source->compile.target = *target;
  source->compile.debugInfo = true;  // OpLine: each site's source line
  auto compiled = gpu::compileShader(*source);
  if (!compiled) return makeError(compiled.error());
  return std::move(compiled->words);
}

// Sets 0 (scene), 1..counterSet-1 (empty), counterSet (counters).
VkPipelineLayout layoutWithCounters(const gpu::Context& ctx, VkDescriptorSetLayout scene,
                                    VkDescriptorSetLayout empty, VkDescriptorSetLayout counters,
                                    uint32_t counterSet, uint32_t pushBytes, VkShaderStageFlags pushStages) {
  std::vector<VkDescriptorSetLayout> sets(counterSet + 1, empty);
  sets[0] = scene;
  sets[counterSet] = counters;
  return gpu::createPipelineLayout(ctx, sets, pushBytes, pushStages);
}

// What one run instruments: the rewritten modules and their sites.
struct InstrumentedModules {
  std::vector<std::vector<uint32_t>> words;
  std::vector<spirv::Site> sites;
  std::vector<std::string> notes;
  uint32_t slotCount = 0;                     // reserved, copies included
  std::vector<spirv::CopyLayout> striped;     // settled after readback (copies, derived counts)
};

// Instruments `modules` (stage, words) in order, each from the slot after the
// previous one's, so that they share one counter buffer without collisions.
Result<InstrumentedModules> instrumentAll(
    const gpu::Context& ctx, const RunOptions& options,
    const std::vector<std::pair<spirv::Stage, const std::vector<uint32_t>*>>& modules) {
  InstrumentedModules out;
  for (const auto& [stage, words] : modules) {
    if (!options.mode) {
      out.words.push_back(*words);
      continue;
    }
    spirv::InstrumentOptions instrumentOptions =
        gpu::instrumentOptionsFor(ctx, *options.mode, out.slotCount, *words);
    instrumentOptions.width = options.width;
    if (options.computeCopies != 0) instrumentOptions.computeCopies = options.computeCopies;
    instrumentOptions.deriveOnceSites = options.deriveOnceSites;
    instrumentOptions.perSite = options.perSite;
    if (auto why = gpu::unsupportedReason(ctx, stage, instrumentOptions); !why.empty()) {
      return makeError(std::string(spirv::toString(stage)) + ": " + why);
    }
    auto result = spirv::instrument(*words, instrumentOptions);
    if (!result) return makeError(std::string(spirv::toString(stage)) + ": " + result.error());
    out.words.push_back(result->words);
    out.sites.insert(out.sites.end(), result->sites.begin(), result->sites.end());
    out.notes.insert(out.notes.end(), result->notes.begin(), result->notes.end());
    out.slotCount += result->layout().reserved();
    if (result->layout().needsSettling()) out.striped.push_back(result->layout());
  }
  return out;
}

// Counts the copies that received counts, then folds them into their slots
// and adds the derived counts (spirv::settleCounters).
void foldStriped(const InstrumentedModules& modules, PassRun& run) {
  for (const auto& l : modules.striped) {
    uint32_t written = 0;
    for (uint32_t k = 0; k < l.copies; ++k) {
      for (uint32_t s = 0; s < l.slotCount; ++s) {
        if (run.counters[size_t(l.firstSlot) + size_t(k) * l.stride + s] != 0) {
          ++written;
          break;
        }
      }
    }
    // A module of one copy that only needs its derived counts is not striped.
    if (l.copies > 1) run.copiesWritten = std::max(run.copiesWritten, written);
    spirv::settleCounters(run.counters, l);
  }
}

// Counter buffer: 64-bit counters, zeroed by every submission.
struct Counters {
  gpu::Buffer buffer;
  VkDescriptorSet set = VK_NULL_HANDLE;
};

Counters createCounters(const gpu::Context& ctx, VkDescriptorPool pool, VkDescriptorSetLayout layout,
                        uint32_t slots) {
  Counters c;
  c.buffer = gpu::createBuffer(ctx, VkDeviceSize(std::max(slots, 1u)) * sizeof(uint64_t),
                               VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                   VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                               gpu::MemoryUse::DeviceLocal);
  c.set = gpu::allocateDescriptorSet(ctx, pool, layout);
  gpu::DescriptorWrite write;
  write.binding = 0;
  write.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  write.buffer = {c.buffer.buffer, 0, VK_WHOLE_SIZE};
  gpu::updateDescriptorSet(ctx, c.set, {&write, 1});
  return c;
}

void destroyCounters(const gpu::Context& ctx, VkDescriptorPool pool, Counters& c) {
  if (c.set != VK_NULL_HANDLE) vkFreeDescriptorSets(ctx.device, pool, 1, &c.set);
  gpu::destroyBuffer(ctx, c.buffer);
  c = Counters{};
}

std::vector<uint64_t> readCounters(const gpu::Context& ctx, const gpu::Buffer& buffer, uint32_t slots) {
  auto bytes = gpu::readBuffer(ctx, buffer, 0, VkDeviceSize(slots) * sizeof(uint64_t));
  std::vector<uint64_t> counters(slots);
  // Little-endian 64-bit counters (the contract of the instrumentation).
  for (uint32_t i = 0; i < slots; ++i) {
    uint64_t v = 0;
    for (int b = 7; b >= 0; --b) v = (v << 8) | bytes[size_t(i) * 8 + size_t(b)];
    counters[i] = v;
  }
  return counters;
}

// Zeroes the counters, or writes `initial` (little-endian 64-bit slots, the
// rest 0) into the first `slots` of them.
void resetCountersCmd(VkCommandBuffer cmd, const gpu::Buffer& buffer, uint32_t slots,
                      const std::vector<uint64_t>& initial) {
  if (initial.empty()) {
    vkCmdFillBuffer(cmd, buffer.buffer, 0, VK_WHOLE_SIZE, 0);
  } else {
    // vkCmdUpdateBuffer takes at most 65536 bytes: 8192 slots, more than these passes use.
    std::vector<uint8_t> bytes(size_t(std::max(slots, 1u)) * sizeof(uint64_t), 0);
    for (size_t i = 0; i < std::min<size_t>(initial.size(), slots); ++i) {
      for (size_t b = 0; b < 8; ++b) bytes[i * 8 + b] = uint8_t(initial[i] >> (8 * b));
    }
    if (bytes.size() > 65536) throw std::runtime_error("initial counters: more than 8192 slots");
    vkCmdUpdateBuffer(cmd, buffer.buffer, 0, bytes.size(), bytes.data());
  }
  VkMemoryBarrier barrier = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT,
                       VK_PIPELINE_STAGE_VERTEX_SHADER_BIT | VK_PIPELINE_STAGE_FRAGMENT_SHADER_BIT |
                           VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
                       0, 1, &barrier, 0, nullptr, 0, nullptr);
}

double median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

double medianAfterWarmup(const std::vector<double>& times) {
  if (times.size() <= 1) return times.empty() ? 0 : times[0];
  return median(std::vector<double>(times.begin() + 1, times.end()));
}

VkDescriptorSetLayoutBinding binding(uint32_t index, VkDescriptorType type, VkShaderStageFlags stages) {
  VkDescriptorSetLayoutBinding b = {};
  b.binding = index;
  b.descriptorType = type;
  b.descriptorCount = 1;
  b.stageFlags = stages;
  return b;
}

}  // namespace

// ---------------------------------------------------------------- fragment

FragmentPass::FragmentPass(const gpu::Context& ctx, uint32_t width, uint32_t height,
                           std::optional<glsl::Target> target, const std::string& fragment,
                           const std::string& vertex)
    : ctx_(ctx), width_(width), height_(height) {
  auto vert = compileFile(ctx, vertex, target);
  auto frag = compileFile(ctx, fragment, target);
  if (!vert) compileError_ = vert.error();
  if (!frag) compileError_ = frag.error();
  if (vert && frag) {
    vertexWords_ = std::move(*vert);
    fragmentWords_ = std::move(*frag);
  }
  counterSet_ = gpu::instrumentOptionsFor(ctx, {}).set;

  for (uint32_t i = 0; i < kFragmentTextures; ++i) {
    textures_[i] = gpu::createImage(ctx, kTextureSize, kTextureSize, kColorFormat,
                                    VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT);
    gpu::uploadImage(ctx, textures_[i], pattern(kTextureSize, kTextureSize, i),
                     VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  }
  target_ = gpu::createImage(ctx, width, height, kColorFormat,
                             VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
  sampler_ = gpu::createSampler(ctx, VK_FILTER_LINEAR, VK_SAMPLER_ADDRESS_MODE_REPEAT);
  VkFormat formats[] = {kColorFormat};
  renderPass_ =
      gpu::createRenderPass(ctx, formats, VK_FORMAT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  VkImageView views[] = {target_.view};
  framebuffer_ = gpu::createFramebuffer(ctx, renderPass_, views, {width, height});

  std::array<VkDescriptorSetLayoutBinding, kFragmentTextures> sceneBindings;
  for (uint32_t i = 0; i < kFragmentTextures; ++i) {
    sceneBindings[i] = binding(i, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER,
                               VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
  }
  sceneLayout_ = gpu::createDescriptorSetLayout(ctx, sceneBindings);
  emptyLayout_ = gpu::createDescriptorSetLayout(ctx, {});
  auto counterBinding = binding(0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_SHADER_STAGE_ALL_GRAPHICS);
  counterLayout_ = gpu::createDescriptorSetLayout(ctx, {&counterBinding, 1});
  pipelineLayout_ = layoutWithCounters(ctx, sceneLayout_, emptyLayout_, counterLayout_, counterSet_, 0, 0);

  VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, kFragmentTextures},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1}};
  pool_ = gpu::createDescriptorPool(ctx, 2, sizes);
  sceneSet_ = gpu::allocateDescriptorSet(ctx, pool_, sceneLayout_);
  std::array<gpu::DescriptorWrite, kFragmentTextures> writes;
  for (uint32_t i = 0; i < kFragmentTextures; ++i) {
    writes[i].binding = i;
    writes[i].type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    writes[i].image = {sampler_, textures_[i].view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  }
  gpu::updateDescriptorSet(ctx, sceneSet_, writes);
}

FragmentPass::~FragmentPass() {
  vkDeviceWaitIdle(ctx_.device);
  vkDestroyDescriptorPool(ctx_.device, pool_, nullptr);
  vkDestroyPipelineLayout(ctx_.device, pipelineLayout_, nullptr);
  vkDestroyDescriptorSetLayout(ctx_.device, counterLayout_, nullptr);
  vkDestroyDescriptorSetLayout(ctx_.device, emptyLayout_, nullptr);
  vkDestroyDescriptorSetLayout(ctx_.device, sceneLayout_, nullptr);
  vkDestroyFramebuffer(ctx_.device, framebuffer_, nullptr);
  vkDestroyRenderPass(ctx_.device, renderPass_, nullptr);
  vkDestroySampler(ctx_.device, sampler_, nullptr);
  gpu::destroyImage(ctx_, target_);
  for (auto& t : textures_) gpu::destroyImage(ctx_, t);
}

Result<PassRun> FragmentPass::run(const RunOptions& options) {
  if (!compileError_.empty()) return makeError(compileError_);
  auto modules = instrumentAll(
      ctx_, options, {{spirv::Stage::Fragment, &fragmentWords_}, {spirv::Stage::Vertex, &vertexWords_}});
  if (!modules) return makeError(modules.error());

  VkShaderModule fragment = VK_NULL_HANDLE, vertex = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  Counters counters;
  gpu::TimestampQueries timestamps;
  gpu::StatisticsQueries statistics;
  Defer cleanup([&] {
    vkDeviceWaitIdle(ctx_.device);
    if (pipeline != VK_NULL_HANDLE) vkDestroyPipeline(ctx_.device, pipeline, nullptr);
    gpu::destroyShaderModule(ctx_, fragment);
    gpu::destroyShaderModule(ctx_, vertex);
    destroyCounters(ctx_, pool_, counters);
    gpu::destroyTimestampQueries(ctx_, timestamps);
    gpu::destroyStatisticsQueries(ctx_, statistics);
  });

  fragment = gpu::createShaderModule(ctx_, modules->words[0]);
  vertex = gpu::createShaderModule(ctx_, modules->words[1]);
  gpu::GraphicsPipelineDesc desc;
  desc.vertex = vertex;
  desc.fragment = fragment;
  desc.layout = pipelineLayout_;
  desc.renderPass = renderPass_;
  pipeline = gpu::createGraphicsPipeline(ctx_, desc);
  counters = createCounters(ctx_, pool_, counterLayout_, modules->slotCount);
  if (ctx_.timestamps) timestamps = gpu::createTimestampQueries(ctx_, 1);
  if (ctx_.pipelineStatistics) {
    statistics =
        gpu::createStatisticsQueries(ctx_, 1,
                                     VK_QUERY_PIPELINE_STATISTIC_VERTEX_SHADER_INVOCATIONS_BIT |
                                         VK_QUERY_PIPELINE_STATISTIC_FRAGMENT_SHADER_INVOCATIONS_BIT);
  }

  PassRun run;
  const VkExtent2D extent = {width_, height_};
  for (uint32_t s = 0; s < std::max(options.submissions, 1u); ++s) {
    const auto start = std::chrono::steady_clock::now();
    gpu::submitAndWait(ctx_, [&](VkCommandBuffer cmd) {
      resetCountersCmd(cmd, counters.buffer, modules->slotCount, options.initialCounters);
      if (timestamps.pool != VK_NULL_HANDLE) gpu::resetTimestamps(cmd, timestamps);
      if (statistics.pool != VK_NULL_HANDLE) gpu::resetStatistics(cmd, statistics);
      if (timestamps.pool != VK_NULL_HANDLE) gpu::writePassBegin(cmd, timestamps, 0);

      VkClearValue clear = {};
      VkRenderPassBeginInfo begin = {VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
      begin.renderPass = renderPass_;
      begin.framebuffer = framebuffer_;
      begin.renderArea = {{0, 0}, extent};
      begin.clearValueCount = 1;
      begin.pClearValues = &clear;
      vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
      // Inside the render pass: lavapipe crashes when the query brackets it.
      if (statistics.pool != VK_NULL_HANDLE) gpu::beginStatistics(cmd, statistics, 0);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelineLayout_, 0, 1, &sceneSet_, 0,
                              nullptr);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipelineLayout_, counterSet_, 1,
                              &counters.set, 0, nullptr);
      gpu::setViewportAndScissor(cmd, extent);
      vkCmdDraw(cmd, 3, 1, 0, 0);
      if (statistics.pool != VK_NULL_HANDLE) gpu::endStatistics(cmd, statistics, 0);
      vkCmdEndRenderPass(cmd);

      if (timestamps.pool != VK_NULL_HANDLE) gpu::writePassEnd(cmd, timestamps, 0);
    });
    run.wallMs.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    if (timestamps.pool != VK_NULL_HANDLE) run.timesMs.push_back(gpu::readPassTimesMs(ctx_, timestamps)[0]);
  }
  run.medianMs = medianAfterWarmup(run.timesMs);
  run.medianWallMs = medianAfterWarmup(run.wallMs);
  if (statistics.pool != VK_NULL_HANDLE) run.statistics = gpu::readStatistics(ctx_, statistics)[0];
  run.counters = readCounters(ctx_, counters.buffer, modules->slotCount);
  foldStriped(*modules, run);
  run.sites = std::move(modules->sites);
  run.notes = std::move(modules->notes);
  run.output = gpu::readImage(ctx_, target_, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
  return run;
}

// ----------------------------------------------------------------- compute

ComputePass::ComputePass(const gpu::Context& ctx, uint32_t width, uint32_t height, const std::string& shader)
    : ctx_(ctx), width_(width), height_(height) {
  auto comp = compileFile(ctx, shader, std::nullopt);
  if (comp) {
    words_ = std::move(*comp);
  } else {
    compileError_ = comp.error();
  }
  counterSet_ = gpu::instrumentOptionsFor(ctx, {}).set;

  source_ = gpu::createImage(ctx, kTextureSize, kTextureSize, kColorFormat,
                             VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT);
  gpu::uploadImage(ctx, source_, pattern(kTextureSize, kTextureSize, 7),
                   VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  inputImage_ = gpu::createImage(ctx, width, height, kColorFormat,
                                 VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT);
  gpu::uploadImage(ctx, inputImage_, pattern(width, height, 3), VK_IMAGE_LAYOUT_GENERAL);
  outputImage_ = gpu::createImage(
      ctx, width, height, kColorFormat,
      VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT);
  gpu::submitAndWait(ctx, [&](VkCommandBuffer cmd) {
    gpu::transitionImage(cmd, outputImage_, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL);
  });

  const VkDeviceSize bytes = VkDeviceSize(width) * height * sizeof(uint32_t);
  inputBuffer_ =
      gpu::createBuffer(ctx, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                        gpu::MemoryUse::DeviceLocal);
  outputBuffer_ = gpu::createBuffer(ctx, bytes,
                                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                        VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                    gpu::MemoryUse::DeviceLocal);
  std::vector<uint32_t> values(size_t(width) * height);
  for (size_t i = 0; i < values.size(); ++i) values[i] = static_cast<uint32_t>(i * 7 + 1);
  gpu::uploadBuffer(ctx, inputBuffer_, {reinterpret_cast<const uint8_t*>(values.data()), bytes});

  sampler_ = gpu::createSampler(ctx, VK_FILTER_NEAREST, VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE);
  VkDescriptorSetLayoutBinding sceneBindings[] = {
      binding(0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, VK_SHADER_STAGE_COMPUTE_BIT),
      binding(1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, VK_SHADER_STAGE_COMPUTE_BIT),
      binding(2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_SHADER_STAGE_COMPUTE_BIT),
      binding(3, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_SHADER_STAGE_COMPUTE_BIT),
      binding(4, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, VK_SHADER_STAGE_COMPUTE_BIT),
      binding(5, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_SHADER_STAGE_COMPUTE_BIT),
  };
  sceneBindings[5].descriptorCount = kComputeBufferArray;
  sceneLayout_ = gpu::createDescriptorSetLayout(ctx, sceneBindings);
  emptyLayout_ = gpu::createDescriptorSetLayout(ctx, {});
  auto counterBinding = binding(0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, VK_SHADER_STAGE_COMPUTE_BIT);
  counterLayout_ = gpu::createDescriptorSetLayout(ctx, {&counterBinding, 1});
  pipelineLayout_ = layoutWithCounters(ctx, sceneLayout_, emptyLayout_, counterLayout_, counterSet_,
                                       2 * sizeof(uint32_t), VK_SHADER_STAGE_COMPUTE_BIT);

  VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 2},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 3 + kComputeBufferArray}};
  pool_ = gpu::createDescriptorPool(ctx, 2, sizes);
  sceneSet_ = gpu::allocateDescriptorSet(ctx, pool_, sceneLayout_);
  gpu::DescriptorWrite writes[5 + kComputeBufferArray];
  writes[0].binding = 0;
  writes[0].type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  writes[0].image = {sampler_, source_.view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  writes[1].binding = 1;
  writes[1].type = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  writes[1].image = {VK_NULL_HANDLE, inputImage_.view, VK_IMAGE_LAYOUT_GENERAL};
  writes[2].binding = 2;
  writes[2].type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  writes[2].buffer = {inputBuffer_.buffer, 0, VK_WHOLE_SIZE};
  writes[3].binding = 3;
  writes[3].type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  writes[3].buffer = {outputBuffer_.buffer, 0, VK_WHOLE_SIZE};
  writes[4].binding = 4;
  writes[4].type = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  writes[4].image = {VK_NULL_HANDLE, outputImage_.view, VK_IMAGE_LAYOUT_GENERAL};
  for (uint32_t i = 0; i < kComputeBufferArray; ++i) {  // every element the input buffer
    writes[5 + i].binding = 5;
    writes[5 + i].arrayElement = i;
    writes[5 + i].type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[5 + i].buffer = {inputBuffer_.buffer, 0, VK_WHOLE_SIZE};
  }
  gpu::updateDescriptorSet(ctx, sceneSet_, writes);
}

ComputePass::~ComputePass() {
  vkDeviceWaitIdle(ctx_.device);
  vkDestroyDescriptorPool(ctx_.device, pool_, nullptr);
  vkDestroyPipelineLayout(ctx_.device, pipelineLayout_, nullptr);
  vkDestroyDescriptorSetLayout(ctx_.device, counterLayout_, nullptr);
  vkDestroyDescriptorSetLayout(ctx_.device, emptyLayout_, nullptr);
  vkDestroyDescriptorSetLayout(ctx_.device, sceneLayout_, nullptr);
  vkDestroySampler(ctx_.device, sampler_, nullptr);
  gpu::destroyBuffer(ctx_, outputBuffer_);
  gpu::destroyBuffer(ctx_, inputBuffer_);
  gpu::destroyImage(ctx_, outputImage_);
  gpu::destroyImage(ctx_, inputImage_);
  gpu::destroyImage(ctx_, source_);
}

Result<PassRun> ComputePass::run(const RunOptions& options) {
  if (!compileError_.empty()) return makeError(compileError_);
  auto modules = instrumentAll(ctx_, options, {{spirv::Stage::Compute, &words_}});
  if (!modules) return makeError(modules.error());

  VkShaderModule shader = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  Counters counters;
  gpu::TimestampQueries timestamps;
  gpu::StatisticsQueries statistics;
  Defer cleanup([&] {
    vkDeviceWaitIdle(ctx_.device);
    if (pipeline != VK_NULL_HANDLE) vkDestroyPipeline(ctx_.device, pipeline, nullptr);
    gpu::destroyShaderModule(ctx_, shader);
    destroyCounters(ctx_, pool_, counters);
    gpu::destroyTimestampQueries(ctx_, timestamps);
    gpu::destroyStatisticsQueries(ctx_, statistics);
  });

  shader = gpu::createShaderModule(ctx_, modules->words[0]);
  pipeline = gpu::createComputePipeline(ctx_, shader, pipelineLayout_);
  counters = createCounters(ctx_, pool_, counterLayout_, modules->slotCount);
  if (ctx_.timestamps) timestamps = gpu::createTimestampQueries(ctx_, 1);
  if (ctx_.pipelineStatistics) {
    statistics =
        gpu::createStatisticsQueries(ctx_, 1, VK_QUERY_PIPELINE_STATISTIC_COMPUTE_SHADER_INVOCATIONS_BIT);
  }

  PassRun run;
  const uint32_t extent[2] = {width_, height_};
  for (uint32_t s = 0; s < std::max(options.submissions, 1u); ++s) {
    const auto start = std::chrono::steady_clock::now();
    gpu::submitAndWait(ctx_, [&](VkCommandBuffer cmd) {
      // Clear the outputs, so that each run's output is its own.
      vkCmdFillBuffer(cmd, outputBuffer_.buffer, 0, VK_WHOLE_SIZE, 0);
      VkClearColorValue black = {};
      VkImageSubresourceRange range = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
      vkCmdClearColorImage(cmd, outputImage_.image, VK_IMAGE_LAYOUT_GENERAL, &black, 1, &range);
      resetCountersCmd(cmd, counters.buffer, modules->slotCount, options.initialCounters);
      if (timestamps.pool != VK_NULL_HANDLE) gpu::resetTimestamps(cmd, timestamps);
      if (statistics.pool != VK_NULL_HANDLE) gpu::resetStatistics(cmd, statistics);
      if (timestamps.pool != VK_NULL_HANDLE) gpu::writePassBegin(cmd, timestamps, 0);
      if (statistics.pool != VK_NULL_HANDLE) gpu::beginStatistics(cmd, statistics, 0);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineLayout_, 0, 1, &sceneSet_, 0,
                              nullptr);
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipelineLayout_, counterSet_, 1,
                              &counters.set, 0, nullptr);
      vkCmdPushConstants(cmd, pipelineLayout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof extent, extent);
      vkCmdDispatch(cmd, groupsX(), groupsY(), 1);
      if (statistics.pool != VK_NULL_HANDLE) gpu::endStatistics(cmd, statistics, 0);
      if (timestamps.pool != VK_NULL_HANDLE) gpu::writePassEnd(cmd, timestamps, 0);
    });
    run.wallMs.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    if (timestamps.pool != VK_NULL_HANDLE) run.timesMs.push_back(gpu::readPassTimesMs(ctx_, timestamps)[0]);
  }
  run.medianMs = medianAfterWarmup(run.timesMs);
  run.medianWallMs = medianAfterWarmup(run.wallMs);
  if (statistics.pool != VK_NULL_HANDLE) run.statistics = gpu::readStatistics(ctx_, statistics)[0];
  run.counters = readCounters(ctx_, counters.buffer, modules->slotCount);
  foldStriped(*modules, run);
  run.sites = std::move(modules->sites);
  run.notes = std::move(modules->notes);
  run.output = gpu::readBuffer(ctx_, outputBuffer_);
  auto image = gpu::readImage(ctx_, outputImage_, VK_IMAGE_LAYOUT_GENERAL);
  run.output.insert(run.output.end(), image.begin(), image.end());
  return run;
}

}  // namespace tally::test
