// A plain Vulkan application for the layer's per-draw counts
// (tests/layer/draws_test.py). Each frame is one primary command buffer with
// three passes into "target" (RGBA8, W x H = 64 x 48); every draw is the
// triangle of attribution_app_setup.cpp clipped to its viewport, so its
// fragments are the viewport's pixels:
//   "scene":     under the label "scene", pipelines "opaque" and "textured"
//                (named) and one left unnamed:
//                  0 "floor" (nested in "scene"), opaque, the whole target;
//                  1 "left wall" (nested in "walls"), opaque, 16 columns;
//                  2 no label of its own, unnamed, 32 columns, 2 instances;
//                  3 "indirect", opaque, vkCmdDrawIndirect of 2 draws of the
//                    whole target (one command);
//                  4 "textured quad", textured, 32 columns, each fragment
//                    reading one texel of "texture".
//   "secondary": a secondary command buffer of two draws, the first under
//                the secondary's label "left half" (32 columns), the second
//                under none (the whole target).
//   "many":      --many M draws, draw i over 1 + i % 16 columns.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "attribution_app.hpp"

using namespace attribution;

namespace {

constexpr const char* kSolid = R"(#version 450
layout(location = 0) in float vShade;
layout(location = 0) out vec4 a;
void main() { a = vec4(vShade); }
)";
constexpr const char* kTextured = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D source;
layout(location = 0) out vec4 a;
void main() { a = texelFetch(source, ivec2(gl_FragCoord.xy), 0); }
)";

constexpr VkFormat kRgba8 = VK_FORMAT_R8G8B8A8_UNORM;

struct Scene {
  Image target, texture;
  VkBuffer triangle = VK_NULL_HANDLE, indirect = VK_NULL_HANDLE;
  VkRenderPass pass = VK_NULL_HANDLE;
  VkFramebuffer framebuffer = VK_NULL_HANDLE;
  VkPipelineLayout plain = VK_NULL_HANDLE, sampling = VK_NULL_HANDLE;
  VkDescriptorSet textureSet = VK_NULL_HANDLE;
  VkPipeline opaque = VK_NULL_HANDLE, unnamed = VK_NULL_HANDLE, textured = VK_NULL_HANDLE;
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer primary = VK_NULL_HANDLE, secondary = VK_NULL_HANDLE;
};

VkBuffer indirectBuffer(const App& app) {
  const VkDrawIndirectCommand draws[] = {{3, 1, 0, 0}, {3, 1, 0, 0}};
  VkBufferCreateInfo info = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = sizeof draws;
  info.usage = VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT;
  VkBuffer buffer;
  check(vkCreateBuffer(app.device, &info, nullptr, &buffer), "vkCreateBuffer (indirect)");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(app.device, buffer, &req);
  VkDeviceMemory memory = app.allocate(req, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
  vkBindBufferMemory(app.device, buffer, memory, 0);
  void* mapped = nullptr;
  vkMapMemory(app.device, memory, 0, VK_WHOLE_SIZE, 0, &mapped);
  std::memcpy(mapped, draws, sizeof draws);
  app.name(VK_OBJECT_TYPE_BUFFER, reinterpret_cast<uint64_t>(buffer), "indirect parameters");
  return buffer;
}

void createLayouts(const App& app, Scene& s) {
  const VkDescriptorType sampled = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER;
  const VkDescriptorSetLayoutBinding binding = {0, sampled, 1, VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
  VkDescriptorSetLayoutCreateInfo setInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  setInfo.bindingCount = 1;
  setInfo.pBindings = &binding;
  VkDescriptorSetLayout setLayout;
  check(vkCreateDescriptorSetLayout(app.device, &setInfo, nullptr, &setLayout), "vkCreateDescriptorSetLayout");
  VkPipelineLayoutCreateInfo info = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  check(vkCreatePipelineLayout(app.device, &info, nullptr, &s.plain), "vkCreatePipelineLayout");
  info.setLayoutCount = 1;
  info.pSetLayouts = &setLayout;
  check(vkCreatePipelineLayout(app.device, &info, nullptr, &s.sampling), "vkCreatePipelineLayout");
  const VkDescriptorPoolSize size = {sampled, 1};
  VkDescriptorPoolCreateInfo poolInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VkDescriptorPool pool;
  check(vkCreateDescriptorPool(app.device, &poolInfo, nullptr, &pool), "vkCreateDescriptorPool");
  VkDescriptorSetAllocateInfo allocate = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  allocate.descriptorPool = pool;
  allocate.descriptorSetCount = 1;
  allocate.pSetLayouts = &setLayout;
  check(vkAllocateDescriptorSets(app.device, &allocate, &s.textureSet), "vkAllocateDescriptorSets");
  VkSamplerCreateInfo samplerInfo = {VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  VkSampler sampler;
  check(vkCreateSampler(app.device, &samplerInfo, nullptr, &sampler), "vkCreateSampler");
  const VkDescriptorImageInfo image = {sampler, s.texture.view, kGeneral};
  VkWriteDescriptorSet write = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  write.dstSet = s.textureSet;
  write.descriptorCount = 1;
  write.descriptorType = sampled;
  write.pImageInfo = &image;
  vkUpdateDescriptorSets(app.device, 1, &write, 0, nullptr);
}

void createScene(App& app, Scene& s) {
  s.target = app.image("target", kRgba8, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT);
  s.texture = app.image("texture", kRgba8, VK_IMAGE_USAGE_SAMPLED_BIT);
  s.triangle = app.vertexBuffer("triangle");
  s.indirect = indirectBuffer(app);
  s.pass = renderPass(app, {kRgba8}, {0}, false);
  s.framebuffer = framebuffer(app, s.pass, {s.target.view});
  createLayouts(app, s);
  const VkShaderModule solid = app.shader(kSolid, tally::spirv::Stage::Fragment);
  s.opaque = pipeline(app, {s.plain, s.pass, {}, {0xF}, false, {}, solid});
  s.unnamed = pipeline(app, {s.plain, s.pass, {}, {0xF}, false, {}, solid});
  s.textured = pipeline(app, {s.sampling, s.pass, {}, {0xF}, false, {}, app.shader(kTextured, tally::spirv::Stage::Fragment)});
  app.name(VK_OBJECT_TYPE_PIPELINE, reinterpret_cast<uint64_t>(s.opaque), "opaque");
  app.name(VK_OBJECT_TYPE_PIPELINE, reinterpret_cast<uint64_t>(s.textured), "textured");
}

// The viewport and scissor [x, x + width) x [0, H).
void columns(VkCommandBuffer cmd, uint32_t x, uint32_t width) {
  const VkViewport viewport = {float(x), 0, float(width), float(kHeight), 0, 1};
  const VkRect2D scissor = {{int32_t(x), 0}, {width, kHeight}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void beginPass(const Scene& s, VkCommandBuffer cmd, VkSubpassContents contents) {
  VkRenderPassBeginInfo info = {VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  info.renderPass = s.pass;
  info.framebuffer = s.framebuffer;
  info.renderArea = {{0, 0}, {kWidth, kHeight}};
  vkCmdBeginRenderPass(cmd, &info, contents);
}

void recordSecondary(const App& app, const Scene& s) {
  VkCommandBufferInheritanceInfo inheritance = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_INFO};
  inheritance.renderPass = s.pass;
  inheritance.framebuffer = s.framebuffer;
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT;
  begin.pInheritanceInfo = &inheritance;
  check(vkBeginCommandBuffer(s.secondary, &begin), "vkBeginCommandBuffer (secondary)");
  vkCmdBindPipeline(s.secondary, VK_PIPELINE_BIND_POINT_GRAPHICS, s.opaque);
  const VkDeviceSize offset = 0;
  vkCmdBindVertexBuffers(s.secondary, 0, 1, &s.triangle, &offset);
  app.label(s.secondary, "left half");
  columns(s.secondary, 0, kWidth / 2);
  vkCmdDraw(s.secondary, 3, 1, 0, 0);
  app.endLabel(s.secondary);
  columns(s.secondary, 0, kWidth);
  vkCmdDraw(s.secondary, 3, 1, 0, 0);
  check(vkEndCommandBuffer(s.secondary), "vkEndCommandBuffer (secondary)");
}

void recordScene(const App& app, const Scene& s, VkCommandBuffer cmd) {
  const auto graphics = VK_PIPELINE_BIND_POINT_GRAPHICS;
  const VkDeviceSize offset = 0;
  app.label(cmd, "scene");
  beginPass(s, cmd, VK_SUBPASS_CONTENTS_INLINE);
  vkCmdBindVertexBuffers(cmd, 0, 1, &s.triangle, &offset);
  vkCmdBindPipeline(cmd, graphics, s.opaque);
  app.label(cmd, "floor");
  columns(cmd, 0, kWidth);
  vkCmdDraw(cmd, 3, 1, 0, 0);
  app.endLabel(cmd);
  app.label(cmd, "walls");
  app.label(cmd, "left wall");
  columns(cmd, 0, 16);
  vkCmdDraw(cmd, 3, 1, 0, 0);
  app.endLabel(cmd);
  app.endLabel(cmd);
  vkCmdBindPipeline(cmd, graphics, s.unnamed);
  columns(cmd, 16, 32);
  vkCmdDraw(cmd, 3, 2, 0, 0);
  vkCmdBindPipeline(cmd, graphics, s.opaque);
  app.label(cmd, "indirect");
  columns(cmd, 0, kWidth);
  vkCmdDrawIndirect(cmd, s.indirect, 0, 2, sizeof(VkDrawIndirectCommand));
  app.endLabel(cmd);
  vkCmdBindPipeline(cmd, graphics, s.textured);
  vkCmdBindDescriptorSets(cmd, graphics, s.sampling, 0, 1, &s.textureSet, 0, nullptr);
  app.label(cmd, "textured quad");
  columns(cmd, 32, 32);
  vkCmdDraw(cmd, 3, 1, 0, 0);
  app.endLabel(cmd);
  vkCmdEndRenderPass(cmd);
  app.endLabel(cmd);
}

void recordFrame(const App& app, const Scene& s, uint32_t many) {
  VkCommandBuffer cmd = s.primary;
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  recordScene(app, s, cmd);
  VkMemoryBarrier barrier = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_MEMORY_WRITE_BIT,
                             VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT};
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1, &barrier, 0,
                       nullptr, 0, nullptr);
  app.label(cmd, "secondary");
  beginPass(s, cmd, VK_SUBPASS_CONTENTS_SECONDARY_COMMAND_BUFFERS);
  vkCmdExecuteCommands(cmd, 1, &s.secondary);
  vkCmdEndRenderPass(cmd);
  app.endLabel(cmd);
  app.label(cmd, "many");
  beginPass(s, cmd, VK_SUBPASS_CONTENTS_INLINE);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, s.opaque);
  const VkDeviceSize offset = 0;
  vkCmdBindVertexBuffers(cmd, 0, 1, &s.triangle, &offset);
  for (uint32_t i = 0; i < many; ++i) {
    columns(cmd, (i * 7) % 48, 1 + i % 16);
    vkCmdDraw(cmd, 3, 1, 0, 0);
  }
  vkCmdEndRenderPass(cmd);
  app.endLabel(cmd);
  check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t frames = 2, many = 1100;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string option = argv[i];
    const uint32_t value = uint32_t(std::strtoul(argv[i + 1], nullptr, 10));
    if (option == "--frames") frames = value;
    if (option == "--many") many = value;
  }
  App app;
  createDevice(app);
  Scene s;
  createScene(app, s);
  s.pool = commandPool(app);
  s.primary = commandBuffer(app, s.pool, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
  s.secondary = commandBuffer(app, s.pool, VK_COMMAND_BUFFER_LEVEL_SECONDARY);
  const VkFence done = fence(app);
  prepareImages(app, s.primary, done);
  for (uint32_t frame = 0; frame < frames; ++frame) {
    recordSecondary(app, s);
    recordFrame(app, s, many);
    submit(app, s.primary, done);
  }
  vkDeviceWaitIdle(app.device);
  std::printf("draws_app: %u frames, %u draws in \"many\"\n", frames, many);
  return 0;
}
