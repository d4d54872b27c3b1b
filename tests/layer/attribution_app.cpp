// A plain Vulkan application for the layer's attribution test
// (tests/layer/attribution_test.py). It never presents: each frame is one
// submission of these passes, each under a debug label, every draw a
// triangle covering its viewport (W x H = 64 x 48 unless said):
//   "split":        a render pass whose subpass has colour Locations 0..3 =
//                   "colour a", VK_ATTACHMENT_UNUSED, "colour b" (write mask
//                   0), "colour c"; the fragment shader writes all four; the
//                   vertex input is dynamic (vkCmdSetVertexInputEXT, binding 1).
//   "depth only":   a render pass with a depth attachment alone; the fragment
//                   shader writes Location 0; vertex strides are dynamic
//                   (vkCmdBindVertexBuffers2).
//   "blit" (twice): dynamic rendering, texelFetch of "colour a" (then "colour
//                   c") into "colour d"; the first scope's Location 1 view is
//                   null, the second's Locations 1 and 2 ("colour g", "colour
//                   h") are turned off by vkCmdSetColorWriteEnableEXT and
//                   vkCmdSetColorWriteMaskEXT.
//   "secondary":    a render pass into "colour e" executing two secondary
//                   command buffers, one inheriting the framebuffer, one
//                   not, each drawing one half of the viewport.
//   "secondary rendering": dynamic rendering into "colour f" executing a
//                   secondary that inherits VkCommandBufferInheritanceRenderingInfo.
//   "discard":      rasterizer discard turned on by vkCmdSetRasterizerDiscardEnable.
//   "multiview":    a render pass with view mask 0b11 into the two layers of "layers".
//   "compute":      8x8 groups over W x H: imageStore("storage out",
//                   imageLoad("storage in") + texelFetch("colour a")).
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "attribution_app.hpp"

using namespace attribution;

namespace {

constexpr const char* kFourOutputs = R"(#version 450
layout(location = 0) in float vShade;
layout(location = 0) out vec4 a;
layout(location = 1) out vec4 b;
layout(location = 2) out vec4 c;
layout(location = 3) out float d;
void main() { a = vec4(vShade); b = a; c = a; d = vShade; }
)";
constexpr const char* kOneOutput = R"(#version 450
layout(location = 0) in float vShade;
layout(location = 0) out vec4 a;
void main() { a = vec4(vShade); }
)";
constexpr const char* kBlit = R"(#version 450
layout(set = 0, binding = 0) uniform sampler2D source;
layout(location = 0) out vec4 a;
layout(location = 1) out vec4 b;
layout(location = 2) out vec4 c;
void main() { a = texelFetch(source, ivec2(gl_FragCoord.xy), 0); b = a; c = a; }
)";
constexpr const char* kCompute = R"(#version 450
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba8) uniform writeonly image2D storageOut;
layout(set = 0, binding = 1, rgba8) uniform readonly image2D storageIn;
layout(set = 0, binding = 2) uniform sampler2D sampled;
void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  imageStore(storageOut, p, imageLoad(storageIn, p) + texelFetch(sampled, p, 0));
}
)";

constexpr VkFormat kRgba8 = VK_FORMAT_R8G8B8A8_UNORM;
constexpr VkColorComponentFlags kAll = 0xF;

struct Scene {
  Image a, b, c, d, g, h, e, f, layers, depth, storageIn, storageOut;
  VkBuffer triangle = VK_NULL_HANDLE, decoy = VK_NULL_HANDLE;
  VkRenderPass split = VK_NULL_HANDLE, depthOnly = VK_NULL_HANDLE, single = VK_NULL_HANDLE, multiview = VK_NULL_HANDLE;
  VkFramebuffer splitTargets = VK_NULL_HANDLE, depthTarget = VK_NULL_HANDLE, singleTarget = VK_NULL_HANDLE,
                multiviewTarget = VK_NULL_HANDLE;
  VkPipelineLayout plain = VK_NULL_HANDLE, sampling = VK_NULL_HANDLE, computeLayout = VK_NULL_HANDLE;
  VkDescriptorSet blitA = VK_NULL_HANDLE, blitC = VK_NULL_HANDLE, computeSet = VK_NULL_HANDLE;
  struct {
    VkPipeline split, depthOnly, blit, blitMasked, secondary, secondaryRendering, discard, multiview, compute;
  } pipelines{};
  VkCommandPool pool = VK_NULL_HANDLE;
  VkCommandBuffer primary = VK_NULL_HANDLE, left = VK_NULL_HANDLE, right = VK_NULL_HANDLE, rendering = VK_NULL_HANDLE;
};

void createTargets(App& app, Scene& s) {
  const VkImageUsageFlags color = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
  s.a = app.image("colour a", kRgba8, color | VK_IMAGE_USAGE_SAMPLED_BIT);
  s.b = app.image("colour b", VK_FORMAT_R16G16B16A16_SFLOAT, color);
  s.c = app.image("colour c", VK_FORMAT_R32_SFLOAT, color | VK_IMAGE_USAGE_SAMPLED_BIT);
  s.d = app.image("colour d", kRgba8, color);
  s.g = app.image("colour g", kRgba8, color);
  s.h = app.image("colour h", kRgba8, color);
  s.e = app.image("colour e", kRgba8, color);
  s.f = app.image("colour f", kRgba8, color);
  s.layers = app.image("layers", kRgba8, color, 2);
  s.depth = app.image("depth", VK_FORMAT_D32_SFLOAT, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT);
  s.storageIn = app.image("storage in", kRgba8, VK_IMAGE_USAGE_STORAGE_BIT);
  s.storageOut = app.image("storage out", kRgba8, VK_IMAGE_USAGE_STORAGE_BIT);
  s.triangle = app.vertexBuffer("triangle");
  s.decoy = app.vertexBuffer("decoy");
  s.split = renderPass(app, {kRgba8, VK_FORMAT_R16G16B16A16_SFLOAT, VK_FORMAT_R32_SFLOAT}, {0, VK_ATTACHMENT_UNUSED, 1, 2},
                       false);
  s.splitTargets = framebuffer(app, s.split, {s.a.view, s.b.view, s.c.view});
  s.depthOnly = renderPass(app, {VK_FORMAT_D32_SFLOAT}, {}, true);
  s.depthTarget = framebuffer(app, s.depthOnly, {s.depth.view});
  s.single = renderPass(app, {kRgba8}, {0}, false);
  s.singleTarget = framebuffer(app, s.single, {s.e.view});
  s.multiview = renderPass(app, {kRgba8}, {0}, false, 0b11);
  s.multiviewTarget = framebuffer(app, s.multiview, {s.layers.view});
}

VkDescriptorSetLayout setLayout(const App& app, const std::vector<VkDescriptorType>& types, VkShaderStageFlags stage) {
  std::vector<VkDescriptorSetLayoutBinding> bindings;
  for (uint32_t i = 0; i < types.size(); ++i) bindings.push_back({i, types[i], 1, stage, nullptr});
  VkDescriptorSetLayoutCreateInfo info = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  info.bindingCount = uint32_t(bindings.size());
  info.pBindings = bindings.data();
  VkDescriptorSetLayout out;
  check(vkCreateDescriptorSetLayout(app.device, &info, nullptr, &out), "vkCreateDescriptorSetLayout");
  return out;
}

VkPipelineLayout pipelineLayout(const App& app, VkDescriptorSetLayout set) {
  VkPipelineLayoutCreateInfo info = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  info.setLayoutCount = set != VK_NULL_HANDLE ? 1 : 0;
  info.pSetLayouts = &set;
  VkPipelineLayout out;
  check(vkCreatePipelineLayout(app.device, &info, nullptr, &out), "vkCreatePipelineLayout");
  return out;
}

void createDescriptors(const App& app, Scene& s) {
  const auto sampled = VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, storage = VK_DESCRIPTOR_TYPE_STORAGE_IMAGE;
  VkDescriptorSetLayout blitLayout = setLayout(app, {sampled}, VK_SHADER_STAGE_FRAGMENT_BIT);
  VkDescriptorSetLayout computeLayout = setLayout(app, {storage, storage, sampled}, VK_SHADER_STAGE_COMPUTE_BIT);
  s.plain = pipelineLayout(app, VK_NULL_HANDLE);
  s.sampling = pipelineLayout(app, blitLayout);
  s.computeLayout = pipelineLayout(app, computeLayout);
  VkDescriptorPoolSize sizes[] = {{sampled, 3}, {storage, 2}};
  VkDescriptorPoolCreateInfo poolInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 3;
  poolInfo.poolSizeCount = 2;
  poolInfo.pPoolSizes = sizes;
  VkDescriptorPool pool;
  check(vkCreateDescriptorPool(app.device, &poolInfo, nullptr, &pool), "vkCreateDescriptorPool");
  VkDescriptorSetLayout layouts[] = {blitLayout, blitLayout, computeLayout};
  VkDescriptorSetAllocateInfo allocate = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  allocate.descriptorPool = pool;
  allocate.descriptorSetCount = 3;
  allocate.pSetLayouts = layouts;
  VkDescriptorSet sets[3];
  check(vkAllocateDescriptorSets(app.device, &allocate, sets), "vkAllocateDescriptorSets");
  s.blitA = sets[0];
  s.blitC = sets[1];
  s.computeSet = sets[2];
  VkSamplerCreateInfo samplerInfo = {VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  VkSampler sampler;
  check(vkCreateSampler(app.device, &samplerInfo, nullptr, &sampler), "vkCreateSampler");
  const VkDescriptorImageInfo images[] = {{sampler, s.a.view, kGeneral}, {sampler, s.c.view, kGeneral},
                                          {VK_NULL_HANDLE, s.storageOut.view, kGeneral},
                                          {VK_NULL_HANDLE, s.storageIn.view, kGeneral}};
  auto write = [&](VkDescriptorSet set, uint32_t binding, VkDescriptorType type, const VkDescriptorImageInfo* image) {
    VkWriteDescriptorSet w = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    w.dstSet = set;
    w.dstBinding = binding;
    w.descriptorCount = 1;
    w.descriptorType = type;
    w.pImageInfo = image;
    vkUpdateDescriptorSets(app.device, 1, &w, 0, nullptr);
  };
  write(s.blitA, 0, sampled, &images[0]);
  write(s.blitC, 0, sampled, &images[1]);
  write(s.computeSet, 0, storage, &images[2]);
  write(s.computeSet, 1, storage, &images[3]);
  write(s.computeSet, 2, sampled, &images[0]);
}

void createPipelines(const App& app, Scene& s) {
  const VkShaderModule four = app.shader(kFourOutputs, tally::spirv::Stage::Fragment);
  const VkShaderModule one = app.shader(kOneOutput, tally::spirv::Stage::Fragment);
  const VkShaderModule blit = app.shader(kBlit, tally::spirv::Stage::Fragment);
  auto& p = s.pipelines;
  p.split = pipeline(app, {s.plain, s.split, {}, {kAll, kAll, 0, kAll}, false, {VK_DYNAMIC_STATE_VERTEX_INPUT_EXT}, four});
  p.depthOnly =
      pipeline(app, {s.plain, s.depthOnly, {}, {}, true, {VK_DYNAMIC_STATE_VERTEX_INPUT_BINDING_STRIDE}, one});
  p.blit = pipeline(app, {s.sampling, VK_NULL_HANDLE, {kRgba8, VK_FORMAT_UNDEFINED}, {kAll, kAll}, false, {}, blit});
  p.blitMasked = pipeline(app, {s.sampling, VK_NULL_HANDLE, {kRgba8, kRgba8, kRgba8}, {kAll, kAll, kAll}, false,
                                {VK_DYNAMIC_STATE_COLOR_WRITE_ENABLE_EXT, VK_DYNAMIC_STATE_COLOR_WRITE_MASK_EXT}, blit});
  p.secondary = pipeline(app, {s.plain, s.single, {}, {kAll}, false, {}, one});
  p.secondaryRendering = pipeline(app, {s.plain, VK_NULL_HANDLE, {kRgba8}, {kAll}, false, {}, one});
  p.discard = pipeline(app, {s.plain, s.single, {}, {kAll}, false, {VK_DYNAMIC_STATE_RASTERIZER_DISCARD_ENABLE}, one});
  p.multiview = pipeline(app, {s.plain, s.multiview, {}, {kAll}, false, {}, one});
  VkComputePipelineCreateInfo info = {VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  info.stage = {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_COMPUTE_BIT,
                app.shader(kCompute, tally::spirv::Stage::Compute), "main", nullptr};
  info.layout = s.computeLayout;
  check(vkCreateComputePipelines(app.device, VK_NULL_HANDLE, 1, &info, nullptr, &p.compute), "vkCreateComputePipelines");
}

// The triangle over the viewport [x, x + width) x [0, H).
void draw(VkCommandBuffer cmd, VkBuffer vertices, uint32_t x = 0, uint32_t width = kWidth) {
  const VkViewport viewport = {float(x), 0, float(width), float(kHeight), 0, 1};
  const VkRect2D scissor = {{int32_t(x), 0}, {width, kHeight}};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
  if (vertices != VK_NULL_HANDLE) {
    const VkDeviceSize offset = 0;
    vkCmdBindVertexBuffers(cmd, 0, 1, &vertices, &offset);
  }
  vkCmdDraw(cmd, 3, 1, 0, 0);
}

void barrier(VkCommandBuffer cmd) {
  VkMemoryBarrier b = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_MEMORY_WRITE_BIT,
                       VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT};
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1, &b, 0,
                       nullptr, 0, nullptr);
}

void beginPass(VkCommandBuffer cmd, VkRenderPass pass, VkFramebuffer target, VkSubpassContents contents) {
  VkRenderPassBeginInfo info = {VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  info.renderPass = pass;
  info.framebuffer = target;
  info.renderArea = {{0, 0}, {kWidth, kHeight}};
  vkCmdBeginRenderPass(cmd, &info, contents);
}

void beginRendering(VkCommandBuffer cmd, const std::vector<VkImageView>& views, VkRenderingFlags flags = 0) {
  std::vector<VkRenderingAttachmentInfo> attachments;
  for (VkImageView v : views) {
    VkRenderingAttachmentInfo a = {VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    a.imageView = v;
    a.imageLayout = kGeneral;
    a.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    attachments.push_back(a);
  }
  VkRenderingInfo info = {VK_STRUCTURE_TYPE_RENDERING_INFO};
  info.flags = flags;
  info.renderArea = {{0, 0}, {kWidth, kHeight}};
  info.layerCount = 1;
  info.colorAttachmentCount = uint32_t(attachments.size());
  info.pColorAttachments = attachments.data();
  vkCmdBeginRendering(cmd, &info);
}

// The secondaries: the left half inherits the framebuffer, the right half
// only the render pass; the third inherits a dynamic-rendering scope.
void recordSecondaries(const Scene& s) {
  auto record = [&](VkCommandBuffer cmd, VkFramebuffer target, uint32_t x, uint32_t width) {
    const VkFormat format = kRgba8;
    VkCommandBufferInheritanceRenderingInfo rendering = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_RENDERING_INFO};
    rendering.colorAttachmentCount = 1;
    rendering.pColorAttachmentFormats = &format;
    rendering.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
    const bool dynamic = cmd == s.rendering;
    VkCommandBufferInheritanceInfo inheritance = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_INHERITANCE_INFO,
                                                  dynamic ? &rendering : nullptr};
    inheritance.renderPass = dynamic ? VK_NULL_HANDLE : s.single;
    inheritance.framebuffer = target;
    VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    begin.flags = VK_COMMAND_BUFFER_USAGE_RENDER_PASS_CONTINUE_BIT;
    begin.pInheritanceInfo = &inheritance;
    check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer (secondary)");
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS,
                      dynamic ? s.pipelines.secondaryRendering : s.pipelines.secondary);
    draw(cmd, s.triangle, x, width);
    check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer (secondary)");
  };
  record(s.left, s.singleTarget, 0, kWidth / 2);
  record(s.right, VK_NULL_HANDLE, kWidth / 2, kWidth / 2);
  record(s.rendering, VK_NULL_HANDLE, 0, kWidth);
}

void recordRenderPasses(const App& app, const Scene& s, VkCommandBuffer cmd) {
  const auto graphics = VK_PIPELINE_BIND_POINT_GRAPHICS;
  app.label(cmd, "split");
  beginPass(cmd, s.split, s.splitTargets, VK_SUBPASS_CONTENTS_INLINE);
  vkCmdBindPipeline(cmd, graphics, s.pipelines.split);
  const VkBuffer buffers[] = {s.decoy, s.triangle};
  const VkDeviceSize offsets[] = {0, 0};
  vkCmdBindVertexBuffers(cmd, 0, 2, buffers, offsets);
  const VkVertexInputBindingDescription2EXT binding = {VK_STRUCTURE_TYPE_VERTEX_INPUT_BINDING_DESCRIPTION_2_EXT,
                                                       nullptr, 1, 16, VK_VERTEX_INPUT_RATE_VERTEX, 1};
  const VkVertexInputAttributeDescription2EXT attributes[] = {
      {VK_STRUCTURE_TYPE_VERTEX_INPUT_ATTRIBUTE_DESCRIPTION_2_EXT, nullptr, 0, 1, VK_FORMAT_R32G32_SFLOAT, 0},
      {VK_STRUCTURE_TYPE_VERTEX_INPUT_ATTRIBUTE_DESCRIPTION_2_EXT, nullptr, 1, 1, VK_FORMAT_R32G32_SFLOAT, 8}};
  app.setVertexInput(cmd, 1, &binding, 2, attributes);
  draw(cmd, VK_NULL_HANDLE);
  vkCmdEndRenderPass(cmd);
  app.endLabel(cmd);
  barrier(cmd);

  app.label(cmd, "depth only");
  beginPass(cmd, s.depthOnly, s.depthTarget, VK_SUBPASS_CONTENTS_INLINE);
  vkCmdBindPipeline(cmd, graphics, s.pipelines.depthOnly);
  const VkDeviceSize offset = 0, stride = 16;
  vkCmdBindVertexBuffers2(cmd, 0, 1, &s.triangle, &offset, nullptr, &stride);
  draw(cmd, VK_NULL_HANDLE);
  vkCmdEndRenderPass(cmd);
  app.endLabel(cmd);
  barrier(cmd);

  app.label(cmd, "secondary");
  beginPass(cmd, s.single, s.singleTarget, VK_SUBPASS_CONTENTS_SECONDARY_COMMAND_BUFFERS);
  const VkCommandBuffer halves[] = {s.left, s.right};
  vkCmdExecuteCommands(cmd, 2, halves);
  vkCmdEndRenderPass(cmd);
  app.endLabel(cmd);
  barrier(cmd);

  app.label(cmd, "discard");
  beginPass(cmd, s.single, s.singleTarget, VK_SUBPASS_CONTENTS_INLINE);
  vkCmdBindPipeline(cmd, graphics, s.pipelines.discard);
  vkCmdSetRasterizerDiscardEnable(cmd, VK_TRUE);
  draw(cmd, s.triangle);
  vkCmdEndRenderPass(cmd);
  app.endLabel(cmd);
  barrier(cmd);

  app.label(cmd, "multiview");
  beginPass(cmd, s.multiview, s.multiviewTarget, VK_SUBPASS_CONTENTS_INLINE);
  vkCmdBindPipeline(cmd, graphics, s.pipelines.multiview);
  draw(cmd, s.triangle);
  vkCmdEndRenderPass(cmd);
  app.endLabel(cmd);
  barrier(cmd);
}

void recordRenderingAndCompute(const App& app, const Scene& s, VkCommandBuffer cmd) {
  const auto graphics = VK_PIPELINE_BIND_POINT_GRAPHICS;
  app.label(cmd, "blit");
  beginRendering(cmd, {s.d.view, VK_NULL_HANDLE});
  vkCmdBindPipeline(cmd, graphics, s.pipelines.blit);
  vkCmdBindDescriptorSets(cmd, graphics, s.sampling, 0, 1, &s.blitA, 0, nullptr);
  draw(cmd, s.triangle);
  vkCmdEndRendering(cmd);
  app.endLabel(cmd);
  barrier(cmd);

  app.label(cmd, "blit");
  beginRendering(cmd, {s.d.view, s.g.view, s.h.view});
  vkCmdBindPipeline(cmd, graphics, s.pipelines.blitMasked);
  const VkBool32 enables[] = {VK_TRUE, VK_FALSE, VK_TRUE};
  const VkColorComponentFlags masks[] = {kAll, kAll, 0};
  app.setColorWriteEnable(cmd, 3, enables);
  app.setColorWriteMask(cmd, 0, 3, masks);
  vkCmdBindDescriptorSets(cmd, graphics, s.sampling, 0, 1, &s.blitC, 0, nullptr);
  draw(cmd, s.triangle);
  vkCmdEndRendering(cmd);
  app.endLabel(cmd);
  barrier(cmd);

  app.label(cmd, "secondary rendering");
  beginRendering(cmd, {s.f.view}, VK_RENDERING_CONTENTS_SECONDARY_COMMAND_BUFFERS_BIT);
  vkCmdExecuteCommands(cmd, 1, &s.rendering);
  vkCmdEndRendering(cmd);
  app.endLabel(cmd);
  barrier(cmd);

  app.label(cmd, "compute");
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s.pipelines.compute);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, s.computeLayout, 0, 1, &s.computeSet, 0, nullptr);
  vkCmdDispatch(cmd, kWidth / 8, kHeight / 8, 1);
  app.endLabel(cmd);
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t frames = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::string(argv[i]) == "--frames") frames = uint32_t(std::strtoul(argv[i + 1], nullptr, 10));
  }
  App app;
  createDevice(app);
  Scene s;
  createTargets(app, s);
  createDescriptors(app, s);
  createPipelines(app, s);
  s.pool = commandPool(app);
  s.primary = commandBuffer(app, s.pool, VK_COMMAND_BUFFER_LEVEL_PRIMARY);
  for (VkCommandBuffer* cmd : {&s.left, &s.right, &s.rendering}) {
    *cmd = commandBuffer(app, s.pool, VK_COMMAND_BUFFER_LEVEL_SECONDARY);
  }
  const VkFence done = fence(app);
  prepareImages(app, s.primary, done);
  for (uint32_t frame = 0; frame < frames; ++frame) {
    recordSecondaries(s);
    VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    check(vkBeginCommandBuffer(s.primary, &begin), "vkBeginCommandBuffer");
    recordRenderPasses(app, s, s.primary);
    recordRenderingAndCompute(app, s, s.primary);
    check(vkEndCommandBuffer(s.primary), "vkEndCommandBuffer");
    submit(app, s.primary, done);
  }
  vkDeviceWaitIdle(app.device);
  std::printf("attribution_app: %u frames\n", frames);
  return 0;
}
