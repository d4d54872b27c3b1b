// A plain Vulkan application for the layer's swapchain test
// (tests/layer/robust_test.py, case resize): an X11 window, a swapchain, and
// each frame one render pass that draws a triangle covering the whole
// framebuffer with a constant colour, so a frame has exactly width x height
// fragment invocations and as many colour writes. After --resize-after
// frames it resizes its window and recreates the swapchain at the new size
// (oldSwapchain set), as applications do when their window changes. It
// prints the extent it rendered each frame at: the test's expected counts.
//
//   swapchain_app --frames N --resize-after K --first WxH --second WxH
#include "app_support.hpp"

// Xlib last: its macros (None, Success, Bool) would reach the headers above.
#include <X11/Xlib.h>
#include <vulkan/vulkan_xlib.h>

namespace {

constexpr const char* kVertex = R"(#version 450
void main() {
  // One triangle over the whole viewport: (-1,-1), (3,-1), (-1,3).
  vec2 p = vec2((gl_VertexIndex & 1) * 4 - 1, (gl_VertexIndex >> 1) * 4 - 1);
  gl_Position = vec4(p, 0.0, 1.0);
}
)";
constexpr const char* kFragment = R"(#version 450
layout(location = 0) out vec4 color;
void main() { color = vec4(0.2, 0.4, 0.8, 1.0); }
)";

VkExtent2D parseSize(const char* text) {
  unsigned w = 0, h = 0;
  if (std::sscanf(text, "%ux%u", &w, &h) != 2 || w == 0 || h == 0) {
    std::fprintf(stderr, "swapchain_app: a size is WxH, got '%s'\n", text);
    std::exit(2);
  }
  return {w, h};
}

VkShaderModule module(VkDevice device, const char* source, tally::spirv::Stage stage) {
  const auto words = app::compile(source, stage);
  VkShaderModuleCreateInfo info = {VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  info.codeSize = words.size() * 4;
  info.pCode = words.data();
  VkShaderModule out;
  app::check(vkCreateShaderModule(device, &info, nullptr, &out), "vkCreateShaderModule");
  return out;
}

VkRenderPass renderPass(VkDevice device, VkFormat format) {
  VkAttachmentDescription color = {};
  color.format = format;
  color.samples = VK_SAMPLE_COUNT_1_BIT;
  color.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  color.stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
  color.stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  color.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  color.finalLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR;
  VkAttachmentReference ref = {0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
  VkSubpassDescription subpass = {};
  subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
  subpass.colorAttachmentCount = 1;
  subpass.pColorAttachments = &ref;
  VkSubpassDependency dependency = {VK_SUBPASS_EXTERNAL, 0, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                                    VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT, 0,
                                    VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT, 0};
  VkRenderPassCreateInfo info = {VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO};
  info.attachmentCount = 1;
  info.pAttachments = &color;
  info.subpassCount = 1;
  info.pSubpasses = &subpass;
  info.dependencyCount = 1;
  info.pDependencies = &dependency;
  VkRenderPass out;
  app::check(vkCreateRenderPass(device, &info, nullptr, &out), "vkCreateRenderPass");
  return out;
}

VkPipeline pipeline(VkDevice device, VkRenderPass pass, VkPipelineLayout layout) {
  VkShaderModule vs = module(device, kVertex, tally::spirv::Stage::Vertex);
  VkShaderModule fs = module(device, kFragment, tally::spirv::Stage::Fragment);
  VkPipelineShaderStageCreateInfo stages[2] = {
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_VERTEX_BIT, vs, "main", nullptr},
      {VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO, nullptr, 0, VK_SHADER_STAGE_FRAGMENT_BIT, fs, "main",
       nullptr}};
  VkPipelineVertexInputStateCreateInfo vertexInput = {VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO};
  VkPipelineInputAssemblyStateCreateInfo assembly = {VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO};
  assembly.topology = VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;
  VkPipelineViewportStateCreateInfo viewport = {VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO};
  viewport.viewportCount = 1;
  viewport.scissorCount = 1;
  VkPipelineRasterizationStateCreateInfo raster = {VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO};
  raster.cullMode = VK_CULL_MODE_NONE;
  raster.lineWidth = 1.0f;
  VkPipelineMultisampleStateCreateInfo multisample = {VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO};
  multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;
  VkPipelineColorBlendAttachmentState blendAttachment = {};
  blendAttachment.colorWriteMask = 0xF;
  VkPipelineColorBlendStateCreateInfo blend = {VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO};
  blend.attachmentCount = 1;
  blend.pAttachments = &blendAttachment;
  const VkDynamicState dynamics[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
  VkPipelineDynamicStateCreateInfo dynamic = {VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO};
  dynamic.dynamicStateCount = 2;
  dynamic.pDynamicStates = dynamics;
  VkGraphicsPipelineCreateInfo info = {VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO};
  info.stageCount = 2;
  info.pStages = stages;
  info.pVertexInputState = &vertexInput;
  info.pInputAssemblyState = &assembly;
  info.pViewportState = &viewport;
  info.pRasterizationState = &raster;
  info.pMultisampleState = &multisample;
  info.pColorBlendState = &blend;
  info.pDynamicState = &dynamic;
  info.layout = layout;
  info.renderPass = pass;
  VkPipeline out;
  app::check(vkCreateGraphicsPipelines(device, VK_NULL_HANDLE, 1, &info, nullptr, &out), "vkCreateGraphicsPipelines");
  vkDestroyShaderModule(device, vs, nullptr);
  vkDestroyShaderModule(device, fs, nullptr);
  return out;
}

// The swapchain and what hangs off its images.
struct Chain {
  VkSwapchainKHR swapchain = VK_NULL_HANDLE;
  VkExtent2D extent{};
  std::vector<VkImageView> views;
  std::vector<VkFramebuffer> framebuffers;
};

void destroyViews(VkDevice device, Chain& chain) {
  for (auto f : chain.framebuffers) vkDestroyFramebuffer(device, f, nullptr);
  for (auto v : chain.views) vkDestroyImageView(device, v, nullptr);
  chain.framebuffers.clear();
  chain.views.clear();
}

// A new swapchain at the surface's current extent, replacing `chain`'s.
void recreate(const app::Device& device, VkSurfaceKHR surface, VkFormat format, VkRenderPass pass, Chain& chain) {
  VkSurfaceCapabilitiesKHR caps;
  app::check(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(device.physical, surface, &caps), "surface capabilities");
  VkSwapchainCreateInfoKHR info = {VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR};
  info.surface = surface;
  info.minImageCount = std::max(caps.minImageCount, 2u);
  info.imageFormat = format;
  info.imageColorSpace = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR;
  info.imageExtent = caps.currentExtent;
  info.imageArrayLayers = 1;
  info.imageUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
  info.preTransform = caps.currentTransform;
  info.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
  info.presentMode = VK_PRESENT_MODE_FIFO_KHR;
  info.clipped = VK_TRUE;
  info.oldSwapchain = chain.swapchain;
  VkSwapchainKHR swapchain;
  app::check(vkCreateSwapchainKHR(device.device, &info, nullptr, &swapchain), "vkCreateSwapchainKHR");
  destroyViews(device.device, chain);
  if (chain.swapchain != VK_NULL_HANDLE) vkDestroySwapchainKHR(device.device, chain.swapchain, nullptr);
  chain.swapchain = swapchain;
  chain.extent = caps.currentExtent;
  uint32_t count = 0;
  vkGetSwapchainImagesKHR(device.device, swapchain, &count, nullptr);
  std::vector<VkImage> images(count);
  vkGetSwapchainImagesKHR(device.device, swapchain, &count, images.data());
  for (VkImage image : images) {
    VkImageViewCreateInfo view = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
    view.image = image;
    view.viewType = VK_IMAGE_VIEW_TYPE_2D;
    view.format = format;
    view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VkImageView v;
    app::check(vkCreateImageView(device.device, &view, nullptr, &v), "vkCreateImageView");
    chain.views.push_back(v);
    VkFramebufferCreateInfo fb = {VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO};
    fb.renderPass = pass;
    fb.attachmentCount = 1;
    fb.pAttachments = &v;
    fb.width = chain.extent.width;
    fb.height = chain.extent.height;
    fb.layers = 1;
    VkFramebuffer f;
    app::check(vkCreateFramebuffer(device.device, &fb, nullptr, &f), "vkCreateFramebuffer");
    chain.framebuffers.push_back(f);
  }
}

void record(VkCommandBuffer cmd, VkRenderPass pass, VkPipeline pipe, const Chain& chain, uint32_t image) {
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  app::check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  VkClearValue clear = {};
  VkRenderPassBeginInfo rp = {VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO};
  rp.renderPass = pass;
  rp.framebuffer = chain.framebuffers[image];
  rp.renderArea = {{0, 0}, chain.extent};
  rp.clearValueCount = 1;
  rp.pClearValues = &clear;
  vkCmdBeginRenderPass(cmd, &rp, VK_SUBPASS_CONTENTS_INLINE);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipe);
  VkViewport viewport = {0, 0, float(chain.extent.width), float(chain.extent.height), 0, 1};
  VkRect2D scissor = {{0, 0}, chain.extent};
  vkCmdSetViewport(cmd, 0, 1, &viewport);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
  vkCmdDraw(cmd, 3, 1, 0, 0);
  vkCmdEndRenderPass(cmd);
  app::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t frames = 8, resizeAfter = 4;
  VkExtent2D first = {96, 64}, second = {160, 120};
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--frames") frames = uint32_t(std::strtoul(argv[i + 1], nullptr, 10));
    else if (flag == "--resize-after") resizeAfter = uint32_t(std::strtoul(argv[i + 1], nullptr, 10));
    else if (flag == "--first") first = parseSize(argv[i + 1]);
    else if (flag == "--second") second = parseSize(argv[i + 1]);
  }
  Display* display = XOpenDisplay(nullptr);
  if (display == nullptr) {
    std::fprintf(stderr, "swapchain_app: cannot open the X display (DISPLAY=%s)\n", std::getenv("DISPLAY"));
    return 1;
  }
  Window window = XCreateSimpleWindow(display, DefaultRootWindow(display), 0, 0, first.width, first.height, 0, 0, 0);
  XMapWindow(display, window);
  XSync(display, False);

  app::Instance instance =
      app::createInstance("swapchain_app", {VK_KHR_SURFACE_EXTENSION_NAME, VK_KHR_XLIB_SURFACE_EXTENSION_NAME});
  VkXlibSurfaceCreateInfoKHR sci = {VK_STRUCTURE_TYPE_XLIB_SURFACE_CREATE_INFO_KHR};
  sci.dpy = display;
  sci.window = window;
  VkSurfaceKHR surface;
  app::check(vkCreateXlibSurfaceKHR(instance.instance, &sci, nullptr, &surface), "vkCreateXlibSurfaceKHR");
  app::Device device = app::createDevice(instance, 1, {VK_KHR_SWAPCHAIN_EXTENSION_NAME});
  VkBool32 presentable = VK_FALSE;
  vkGetPhysicalDeviceSurfaceSupportKHR(device.physical, device.family, surface, &presentable);
  if (!presentable) {
    std::fprintf(stderr, "swapchain_app: the queue family cannot present to the window\n");
    return 1;
  }
  uint32_t formatCount = 1;
  VkSurfaceFormatKHR format;
  vkGetPhysicalDeviceSurfaceFormatsKHR(device.physical, surface, &formatCount, &format);

  VkRenderPass pass = renderPass(device.device, format.format);
  VkPipelineLayoutCreateInfo plci = {VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  VkPipelineLayout layout;
  app::check(vkCreatePipelineLayout(device.device, &plci, nullptr, &layout), "vkCreatePipelineLayout");
  VkPipeline pipe = pipeline(device.device, pass, layout);
  Chain chain;
  recreate(device, surface, format.format, pass, chain);
  VkCommandPool pool = app::createPool(device);
  VkCommandBuffer cmd = app::allocate(device, pool);
  VkFence fence = app::createFence(device);
  VkSemaphoreCreateInfo semInfo = {VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
  VkSemaphore acquired, rendered;
  app::check(vkCreateSemaphore(device.device, &semInfo, nullptr, &acquired), "vkCreateSemaphore");
  app::check(vkCreateSemaphore(device.device, &semInfo, nullptr, &rendered), "vkCreateSemaphore");

  for (uint32_t f = 0; f < frames; ++f) {
    if (f == resizeAfter) {
      XResizeWindow(display, window, second.width, second.height);
      XSync(display, False);
      vkDeviceWaitIdle(device.device);
      recreate(device, surface, format.format, pass, chain);
    }
    uint32_t image = 0;
    VkResult r = vkAcquireNextImageKHR(device.device, chain.swapchain, UINT64_MAX, acquired, VK_NULL_HANDLE, &image);
    if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR) app::check(r, "vkAcquireNextImageKHR");
    record(cmd, pass, pipe, chain, image);
    const VkPipelineStageFlags waitStage = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    VkSubmitInfo submit = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
    submit.waitSemaphoreCount = 1;
    submit.pWaitSemaphores = &acquired;
    submit.pWaitDstStageMask = &waitStage;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    submit.signalSemaphoreCount = 1;
    submit.pSignalSemaphores = &rendered;
    app::check(vkQueueSubmit(device.queues[0], 1, &submit, fence), "vkQueueSubmit");
    VkPresentInfoKHR present = {VK_STRUCTURE_TYPE_PRESENT_INFO_KHR};
    present.waitSemaphoreCount = 1;
    present.pWaitSemaphores = &rendered;
    present.swapchainCount = 1;
    present.pSwapchains = &chain.swapchain;
    present.pImageIndices = &image;
    r = vkQueuePresentKHR(device.queues[0], &present);
    if (r != VK_SUCCESS && r != VK_SUBOPTIMAL_KHR) app::check(r, "vkQueuePresentKHR");
    app::wait(device, fence);
    std::printf("swapchain_app: frame %u extent %ux%u\n", f, chain.extent.width, chain.extent.height);
  }
  vkDeviceWaitIdle(device.device);
  vkDestroySemaphore(device.device, acquired, nullptr);
  vkDestroySemaphore(device.device, rendered, nullptr);
  vkDestroyFence(device.device, fence, nullptr);
  vkDestroyCommandPool(device.device, pool, nullptr);
  destroyViews(device.device, chain);
  vkDestroySwapchainKHR(device.device, chain.swapchain, nullptr);
  vkDestroyPipeline(device.device, pipe, nullptr);
  vkDestroyPipelineLayout(device.device, layout, nullptr);
  vkDestroyRenderPass(device.device, pass, nullptr);
  vkDestroyDevice(device.device, nullptr);
  vkDestroySurfaceKHR(instance.instance, surface, nullptr);
  vkDestroyInstance(instance.instance, nullptr);
  XDestroyWindow(display, window);
  XCloseDisplay(display);
  return 0;
}
