#include "footprint_pass.hpp"

#include <cstring>
#include <functional>
#include <set>

#include <spirv-tools/optimizer.hpp>

#include "gpu/footprint.hpp"
#include "gpu/pipelines.hpp"
#include "gpu/resources.hpp"
#include "gpu/shaders.hpp"
#include "gpu/vk_check.hpp"
#include "renderers/scene_images.hpp"
#include "spirv/footprint.hpp"

namespace tally::test {

namespace fp = spirv::footprint;

TileDims rgba8Tile(uint32_t blockBytes) {
  switch (blockBytes) {
    case 32: return {4, 2};   // 8 texels
    case 64: return {4, 4};   // 16 texels
    case 128: return {8, 4};  // 32 texels
  }
  return {1, 1};
}

uint64_t rgba8Blocks(uint32_t width, uint32_t height, uint32_t blockBytes) {
  TileDims t = rgba8Tile(blockBytes);
  return uint64_t((width + t.w - 1) / t.w) * ((height + t.h - 1) / t.h);
}

std::string lineKey(const spirv::Site& s) {
  bool write = s.kind == spirv::SiteKind::BufferWrite || s.kind == spirv::SiteKind::ImageWrite ||
               s.kind == spirv::SiteKind::OutputWrite;
  std::string what = s.kind == spirv::SiteKind::OutputWrite ? "target" : "binding " + std::to_string(s.binding);
  return what + (write ? " write" : " read");
}

Result<PassResult> FootprintPass::run(const PassDesc& d) {
  const spirv::Stage stage = d.compute ? spirv::Stage::Compute : spirv::Stage::Fragment;
  glsl::CompileOptions compile;
  compile.target = gpu::glslTarget(ctx_);
  auto main = glsl::compile(d.source, stage, compile);
  if (!main) return makeError(main.error());
  if (d.optimize) {
    const uint32_t minor = ((*main)[1] >> 8) & 0xff;
    spvtools::Optimizer optimizer(minor >= 6   ? SPV_ENV_VULKAN_1_3
                                  : minor == 5 ? SPV_ENV_VULKAN_1_2
                                  : minor == 4 ? SPV_ENV_VULKAN_1_1_SPIRV_1_4
                                  : minor == 3 ? SPV_ENV_VULKAN_1_1
                                               : SPV_ENV_VULKAN_1_0);
    optimizer.RegisterPerformancePasses();
    std::vector<uint32_t> out;
    if (!optimizer.Run(main->data(), main->size(), &out)) return makeError("the optimizer refused the module");
    *main = std::move(out);
  }
  std::vector<std::pair<spirv::Stage, std::vector<uint32_t>>> modules = {{stage, *main}};
  if (!d.compute) {
    auto vert = glsl::compile(
        "#version 450\nvoid main() { vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);\n"
        "  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }\n",
        spirv::Stage::Vertex, compile);
    if (!vert) return makeError(vert.error());
    modules.push_back({spirv::Stage::Vertex, *vert});
  }
  // Instrument every module into one counter buffer.
  std::vector<spirv::Site> sites;
  std::vector<spirv::CopyLayout> layouts;
  std::vector<std::vector<uint32_t>> words;
  std::vector<uint32_t> arithmeticSlots;
  PassResult out;
  uint32_t slots = 0;
  for (auto& [s, w] : modules) {
    auto options = gpu::instrumentOptionsFor(ctx_, d.mode, slots, w);
    options.footprintDedup = d.dedup;
    options.footprintBlockBytes = d.blockBytes;
    options.countArithmetic = d.countArithmetic;
    options.deriveOnceSites = d.deriveOnceSites;
    if (auto why = gpu::unsupportedReason(ctx_, s, options); !why.empty()) return makeError(why);
    auto r = spirv::instrument(w, options);
    if (!r) return makeError(r.error());
    words.push_back(r->words);
    sites.insert(sites.end(), r->sites.begin(), r->sites.end());
    out.notes.insert(out.notes.end(), r->notes.begin(), r->notes.end());
    if (r->footprintDedup) out.dedup.push_back(*r->footprintDedup);
    layouts.push_back(r->layout());
    if (r->arithmeticSlot >= 0) arithmeticSlots.push_back(uint32_t(r->arithmeticSlot));
    out.derived += r->derived.size();
    slots += r->layout().reserved();
  }
  counterSet_ = gpu::instrumentOptionsFor(ctx_, {}).set;

  // Resources.
  std::vector<renderers::MipImage> textures;
  std::vector<VkSampler> samplers;
  std::vector<gpu::Buffer> buffers;
  gpu::Image target;
  gpu::Buffer counters;
  gpu::FootprintTable table;
  VkDescriptorSetLayout sceneLayout = VK_NULL_HANDLE, emptyLayout = VK_NULL_HANDLE, counterLayout = VK_NULL_HANDLE;
  VkPipelineLayout pipelineLayout = VK_NULL_HANDLE;
  VkDescriptorPool pool = VK_NULL_HANDLE;
  VkRenderPass renderPass = VK_NULL_HANDLE;
  VkFramebuffer framebuffer = VK_NULL_HANDLE;
  VkPipeline pipeline = VK_NULL_HANDLE;
  std::vector<VkShaderModule> shaderModules;
  struct Cleanup {
    std::function<void()> fn;
    ~Cleanup() { fn(); }
  } cleanup{[&] {
    vkDeviceWaitIdle(ctx_.device);
    if (pipeline) vkDestroyPipeline(ctx_.device, pipeline, nullptr);
    for (auto& m : shaderModules) gpu::destroyShaderModule(ctx_, m);
    if (framebuffer) vkDestroyFramebuffer(ctx_.device, framebuffer, nullptr);
    if (renderPass) vkDestroyRenderPass(ctx_.device, renderPass, nullptr);
    if (pool) vkDestroyDescriptorPool(ctx_.device, pool, nullptr);
    if (pipelineLayout) vkDestroyPipelineLayout(ctx_.device, pipelineLayout, nullptr);
    for (auto l : {sceneLayout, emptyLayout, counterLayout}) {
      if (l) vkDestroyDescriptorSetLayout(ctx_.device, l, nullptr);
    }
    for (auto& t : textures) renderers::destroyMipImage(ctx_, t);
    for (auto s : samplers) vkDestroySampler(ctx_.device, s, nullptr);
    for (auto& b : buffers) gpu::destroyBuffer(ctx_, b);
    gpu::destroyImage(ctx_, target);
    gpu::destroyBuffer(ctx_, counters);
    table.destroy();
  }};

  for (const auto& t : d.textures) {
    uint32_t levels = renderers::mipLevels(t.size, t.size);
    textures.push_back(
        renderers::createMipImage(ctx_, t.size, t.size, levels, 1, VK_FORMAT_R8G8B8A8_UNORM, VK_IMAGE_VIEW_TYPE_2D));
    std::vector<uint8_t> texels(size_t(t.size) * t.size * 4);
    for (size_t i = 0; i < texels.size(); ++i) texels[i] = uint8_t(i * 37 + 11);
    renderers::uploadWithMips(ctx_, textures.back(), texels);
    samplers.push_back(gpu::createSampler(ctx_, t.filter, t.address));
  }
  for (VkDeviceSize bytes : d.buffers) {
    buffers.push_back(gpu::createBuffer(ctx_, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                        gpu::MemoryUse::DeviceLocal));
    std::vector<uint8_t> data(bytes);
    for (size_t i = 0; i < data.size(); ++i) data[i] = uint8_t(i * 13 + 5);
    gpu::uploadBuffer(ctx_, buffers.back(), data);
  }
  counters = gpu::createBuffer(ctx_, VkDeviceSize(std::max(slots, 1u)) * 8,
                               VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                   VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                               gpu::MemoryUse::DeviceLocal);

  // The table: one bank; each marked site's slot describes what is bound there.
  table.configure(d.blockBytes, slots);
  table.addBank();
  const uint32_t nTextures = static_cast<uint32_t>(d.textures.size());
  for (const auto& s : sites) {
    if (!s.footprint) continue;
    std::string key = lineKey(s);
    if (s.kind == spirv::SiteKind::OutputWrite) {
      fp::ImageGeometry g{d.width, d.height, 1, 1, 4, 0, 1, 0};
      table.set(0, s.slot, fp::imageEntry(g, d.blockBytes, table.region(key, fp::imageBlocks(g, d.blockBytes))));
    } else if (s.binding >= 0 && uint32_t(s.binding) < nTextures) {
      const TextureDesc& t = d.textures[size_t(s.binding)];
      VkSamplerMipmapMode mip = t.filter == VK_FILTER_LINEAR ? VK_SAMPLER_MIPMAP_MODE_LINEAR : VK_SAMPLER_MIPMAP_MODE_NEAREST;
      fp::ImageGeometry g{t.size, t.size, renderers::mipLevels(t.size, t.size), 1, 4, 0, 0,
                          gpu::samplerBits(t.filter, t.filter, mip, t.address, t.address)};
      table.set(0, s.slot, fp::imageEntry(g, d.blockBytes, table.region(key, fp::imageBlocks(g, d.blockBytes))));
    } else if (s.binding >= 0) {
      VkDeviceSize bytes = d.buffers.at(size_t(s.binding) - nTextures);
      table.set(0, s.slot,
                fp::bufferEntry(bytes, d.blockBytes, table.region(key, fp::bufferBlocks(bytes, d.blockBytes))));
    }
  }
  table.create(ctx_);

  // Layouts and sets: set 0 the scene, the counter set the counters, table and bitmaps.
  std::vector<VkDescriptorSetLayoutBinding> sceneBindings;
  const VkShaderStageFlags stages = d.compute ? VK_SHADER_STAGE_COMPUTE_BIT : VK_SHADER_STAGE_ALL_GRAPHICS;
  for (uint32_t i = 0; i < nTextures + d.buffers.size(); ++i) {
    sceneBindings.push_back({i, i < nTextures ? VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                             1, stages, nullptr});
  }
  sceneLayout = gpu::createDescriptorSetLayout(ctx_, sceneBindings);
  emptyLayout = gpu::createDescriptorSetLayout(ctx_, {});
  VkDescriptorSetLayoutBinding counterBindings[] = {
      {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, stages, nullptr},
      {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC, 1, stages, nullptr},
      {2, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, stages, nullptr}};
  counterLayout = gpu::createDescriptorSetLayout(ctx_, counterBindings);
  std::vector<VkDescriptorSetLayout> setLayouts(counterSet_ + 1, emptyLayout);
  setLayouts[0] = sceneLayout;
  setLayouts[counterSet_] = counterLayout;
  pipelineLayout = gpu::createPipelineLayout(ctx_, setLayouts, 0, 0);
  VkDescriptorPoolSize sizes[] = {{VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, std::max(nTextures, 1u)},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, uint32_t(d.buffers.size()) + 2},
                                  {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC, 1}};
  pool = gpu::createDescriptorPool(ctx_, 2, sizes);
  VkDescriptorSet sceneSet = gpu::allocateDescriptorSet(ctx_, pool, sceneLayout);
  VkDescriptorSet counterSet = gpu::allocateDescriptorSet(ctx_, pool, counterLayout);
  std::vector<gpu::DescriptorWrite> writes;
  for (uint32_t i = 0; i < nTextures; ++i) {
    gpu::DescriptorWrite w;
    w.binding = i;
    w.type = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
    w.image = {samplers[i], textures[i].view, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
    writes.push_back(w);
  }
  for (uint32_t i = 0; i < d.buffers.size(); ++i) {
    gpu::DescriptorWrite w;
    w.binding = nTextures + i;
    w.type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    w.buffer = {buffers[i].buffer, 0, VK_WHOLE_SIZE};
    writes.push_back(w);
  }
  gpu::updateDescriptorSet(ctx_, sceneSet, writes);
  gpu::DescriptorWrite cw[3];
  cw[0].binding = 0;
  cw[0].type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  cw[0].buffer = {counters.buffer, 0, VK_WHOLE_SIZE};
  auto fw = table.descriptorWrites(1, 2);
  cw[1] = fw[0];
  cw[2] = fw[1];
  gpu::updateDescriptorSet(ctx_, counterSet, cw);

  for (const auto& w : words) shaderModules.push_back(gpu::createShaderModule(ctx_, w));
  if (d.compute) {
    pipeline = gpu::createComputePipeline(ctx_, shaderModules[0], pipelineLayout);
  } else {
    target = gpu::createImage(ctx_, d.width, d.height, VK_FORMAT_R8G8B8A8_UNORM,
                              VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT);
    VkFormat formats[] = {VK_FORMAT_R8G8B8A8_UNORM};
    renderPass = gpu::createRenderPass(ctx_, formats);
    VkImageView views[] = {target.view};
    framebuffer = gpu::createFramebuffer(ctx_, renderPass, views, {d.width, d.height});
    gpu::GraphicsPipelineDesc g;
    g.fragment = shaderModules[0];
    g.vertex = shaderModules[1];
    g.layout = pipelineLayout;
    g.renderPass = renderPass;
    pipeline = gpu::createGraphicsPipeline(ctx_, g);
  }

  const uint32_t dynamicOffset = table.bankOffset(0);
  const VkPipelineBindPoint point = d.compute ? VK_PIPELINE_BIND_POINT_COMPUTE : VK_PIPELINE_BIND_POINT_GRAPHICS;
  gpu::submitAndWait(ctx_, [&](VkCommandBuffer cmd) {
    vkCmdFillBuffer(cmd, counters.buffer, 0, VK_WHOLE_SIZE, 0);
    table.recordClear(cmd);
    vkCmdBindPipeline(cmd, point, pipeline);
    vkCmdBindDescriptorSets(cmd, point, pipelineLayout, 0, 1, &sceneSet, 0, nullptr);
    vkCmdBindDescriptorSets(cmd, point, pipelineLayout, counterSet_, 1, &counterSet, 1, &dynamicOffset);
    if (d.compute) {
      vkCmdDispatch(cmd, (d.width + 7) / 8, (d.height + 7) / 8, 1);
      return;
    }
    VkClearValue clear = {};
    VkRenderPassBeginInfo begin = {VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
    begin.renderPass = renderPass;
    begin.framebuffer = framebuffer;
    begin.renderArea = {{0, 0}, {d.width, d.height}};
    begin.clearValueCount = 1;
    begin.pClearValues = &clear;
    vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
    gpu::setViewportAndScissor(cmd, {d.width, d.height});
    vkCmdDraw(cmd, 3, 1, 0, 0);
    vkCmdEndRenderPass(cmd);
  });

  auto bytes = gpu::readBuffer(ctx_, counters, 0, VkDeviceSize(std::max(slots, 1u)) * 8);
  std::vector<uint64_t> counts(bytes.size() / 8);
  std::memcpy(counts.data(), bytes.data(), counts.size() * 8);
  for (const auto& l : layouts) {
    if (l.needsSettling()) spirv::settleCounters(counts, l);
  }
  for (uint32_t slot : arithmeticSlots) out.arithmetic += counts[slot];
  std::vector<uint32_t> bitmap = table.read();
  std::set<uint32_t> seen;
  for (const auto& s : sites) {
    if (s.kind == spirv::SiteKind::Invocation || !seen.insert(s.slot).second) continue;
    std::string key = lineKey(s);
    uint64_t element = s.elementBytes != 0 ? s.elementBytes : 4;  // RGBA8 texels and target
    out.lines[key].requestedBytes += counts[s.slot] * element;
    out.lines[key].blocks = table.blocks(bitmap, key);
  }
  return out;
}

}  // namespace tally::test
