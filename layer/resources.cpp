// The layer's intercepts for resources: images, buffers, their views and
// names, swapchains, render passes and framebuffers (docs/layer.md).
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>
#include <utility>

#include "descriptor_buffers_layer.hpp"
#include "early_tests_twin.hpp"
#include "intercepts.hpp"
#include "libraries.hpp"
#include "names.hpp"
#include "shader_options.hpp"
#include "state.hpp"
#include "uncounted.hpp"

namespace tally::layer {
namespace {

VKAPI_ATTR VkResult VKAPI_CALL CreateImage(VkDevice device, const VkImageCreateInfo* info,
                                           const VkAllocationCallbacks* alloc, VkImage* image) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateImage(device, info, alloc, image);
  if (result != VK_SUCCESS) return result;
  Resource r;
  r.handle = u64(*image);
  r.image = true;
  r.kind = (info->usage & VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT) ? Kind::Depth
           : (info->usage & VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT)       ? Kind::Attachment
                                                                        : Kind::Texture;
  r.imageUsage = info->usage;
  r.format = info->format;
  r.width = info->extent.width;
  r.height = info->extent.height;
  r.samples = info->samples;
  r.usage = imageUsageName(info->usage);
  VkMemoryRequirements req{};
  dev->d.GetImageMemoryRequirements(device, *image, &req);
  r.size = req.size;
  std::lock_guard lock(dev->mutex);
  dev->resources[r.handle] = r;
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateBuffer(VkDevice device, const VkBufferCreateInfo* info,
                                            const VkAllocationCallbacks* alloc, VkBuffer* buffer) {
  DeviceState* dev = deviceOf(device);
  // Indirect parameters are copied after their draws (indirect.cpp).
  VkBufferCreateInfo patched = *info;
  if (dev->counting && (info->usage & VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT)) patched.usage |= VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  VkResult result = dev->d.CreateBuffer(device, &patched, alloc, buffer);
  if (result != VK_SUCCESS) return result;
  Resource r;
  r.handle = u64(*buffer);
  r.size = info->size;
  r.usage = bufferUsageName(info->usage);
  std::lock_guard lock(dev->mutex);
  dev->resources[r.handle] = r;
  noteBufferUsage(*dev, *buffer, info->usage);
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateImageView(VkDevice device, const VkImageViewCreateInfo* info,
                                               const VkAllocationCallbacks* alloc, VkImageView* view) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateImageView(device, info, alloc, view);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  dev->views[u64(*view)] = {u64(info->image), info->format, info->subresourceRange.aspectMask};
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateBufferView(VkDevice device, const VkBufferViewCreateInfo* info,
                                                const VkAllocationCallbacks* alloc, VkBufferView* view) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateBufferView(device, info, alloc, view);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  dev->bufferViews[u64(*view)] = u64(info->buffer);
  return result;
}

// What the layer forgets of destroyed objects (lifetimes.cpp): views and
// framebuffers at once (a recorded draw keeps what it resolved), resources
// once no readback can name them.
template <class Handle, class Forget, class CallDown>
void destroyObject(VkDevice device, Handle handle, Forget forget, CallDown callDown) {
  DeviceState* dev = deviceOf(device);
  if (handle != VK_NULL_HANDLE) {
    std::lock_guard lock(dev->mutex);
    forget(*dev, u64(handle));
  }
  callDown(*dev);
}

VKAPI_ATTR void VKAPI_CALL DestroyImage(VkDevice device, VkImage image, const VkAllocationCallbacks* alloc) {
  destroyObject(device, image, retireResource, [&](DeviceState& dev) { dev.d.DestroyImage(device, image, alloc); });
}
VKAPI_ATTR void VKAPI_CALL DestroyBuffer(VkDevice device, VkBuffer buffer, const VkAllocationCallbacks* alloc) {
  auto forget = [](DeviceState& dev, uint64_t handle) {
    forgetAddress(dev, handle);
    retireResource(dev, handle);
  };
  destroyObject(device, buffer, forget, [&](DeviceState& dev) { dev.d.DestroyBuffer(device, buffer, alloc); });
}
VKAPI_ATTR void VKAPI_CALL DestroyImageView(VkDevice device, VkImageView view, const VkAllocationCallbacks* alloc) {
  destroyObject(device, view, [](DeviceState& dev, uint64_t h) { dev.views.erase(h); },
                [&](DeviceState& dev) { dev.d.DestroyImageView(device, view, alloc); });
}
VKAPI_ATTR void VKAPI_CALL DestroyBufferView(VkDevice device, VkBufferView view, const VkAllocationCallbacks* alloc) {
  destroyObject(device, view, [](DeviceState& dev, uint64_t h) { dev.bufferViews.erase(h); },
                [&](DeviceState& dev) { dev.d.DestroyBufferView(device, view, alloc); });
}
VKAPI_ATTR void VKAPI_CALL DestroyFramebuffer(VkDevice device, VkFramebuffer framebuffer,
                                              const VkAllocationCallbacks* alloc) {
  destroyObject(device, framebuffer, [](DeviceState& dev, uint64_t h) { dev.framebuffers.erase(h); },
                [&](DeviceState& dev) { dev.d.DestroyFramebuffer(device, framebuffer, alloc); });
}

VKAPI_ATTR VkResult VKAPI_CALL SetDebugUtilsObjectNameEXT(VkDevice device, const VkDebugUtilsObjectNameInfoEXT* info) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.SetDebugUtilsObjectNameEXT != nullptr ? dev->d.SetDebugUtilsObjectNameEXT(device, info)
                                                                  : VK_SUCCESS;
  std::lock_guard lock(dev->mutex);
  const std::string name = info->pObjectName != nullptr ? info->pObjectName : "";
  if (auto it = dev->resources.find(info->objectHandle); it != dev->resources.end()) it->second.name = name;
  if (auto it = dev->shaders.find(info->objectHandle); it != dev->shaders.end()) it->second.name = name;
  // A pipeline's name names its draws (TALLY_LAYER_DRAWS).
  if (info->objectType == VK_OBJECT_TYPE_PIPELINE) {
    if (auto it = dev->pipelines.find(info->objectHandle); it != dev->pipelines.end()) it->second->name = name;
  }
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateSwapchainKHR(VkDevice device, const VkSwapchainCreateInfoKHR* info,
                                                  const VkAllocationCallbacks* alloc, VkSwapchainKHR* swapchain) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateSwapchainKHR(device, info, alloc, swapchain);
  if (result != VK_SUCCESS) return result;
  std::lock_guard lock(dev->mutex);
  dev->swapchains[u64(*swapchain)] = {info->imageFormat, info->imageExtent};
  dev->extent = info->imageExtent;
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL GetSwapchainImagesKHR(VkDevice device, VkSwapchainKHR swapchain, uint32_t* count,
                                                     VkImage* images) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.GetSwapchainImagesKHR(device, swapchain, count, images);
  if (images == nullptr || (result != VK_SUCCESS && result != VK_INCOMPLETE)) return result;
  std::lock_guard lock(dev->mutex);
  auto [format, extent] = dev->swapchains[u64(swapchain)];
  for (uint32_t i = 0; i < *count; ++i) {
    Resource r;
    r.handle = u64(images[i]);
    r.image = true;
    r.kind = Kind::Attachment;
    r.format = format;
    r.width = extent.width;
    r.height = extent.height;
    r.size = uint64_t(extent.width) * extent.height * formatBytes(format);
    r.usage = "swapchain";
    r.name = "swapchain";  // every image of the chain is one line
    dev->resources[r.handle] = r;
  }
  return result;
}

// ---------------------------------------------------------------- render passes

// Each subpass's colour attachment references (their Locations' attachments).
template <class Info>
std::vector<std::vector<uint32_t>> subpassColors(const Info& info) {
  std::vector<std::vector<uint32_t>> subpasses;
  for (uint32_t s = 0; s < info.subpassCount; ++s) {
    std::vector<uint32_t> colors;
    for (uint32_t c = 0; c < info.pSubpasses[s].colorAttachmentCount; ++c) {
      colors.push_back(info.pSubpasses[s].pColorAttachments[c].attachment);
    }
    subpasses.push_back(std::move(colors));
  }
  return subpasses;
}

void recordRenderPass(DeviceState& dev, VkRenderPass pass, std::vector<std::vector<uint32_t>> subpasses,
                      std::vector<uint32_t> viewMasks) {
  std::lock_guard lock(dev.mutex);
  dev.renderPasses[u64(pass)] = std::move(subpasses);
  dev.subpassViewMasks.erase(u64(pass));  // a later render pass may reuse the handle
  if (!viewMasks.empty()) dev.subpassViewMasks[u64(pass)] = std::move(viewMasks);
}

VKAPI_ATTR VkResult VKAPI_CALL CreateRenderPass(VkDevice device, const VkRenderPassCreateInfo* info,
                                                const VkAllocationCallbacks* alloc, VkRenderPass* pass) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateRenderPass(device, info, alloc, pass);
  if (result != VK_SUCCESS) return result;
  std::vector<uint32_t> viewMasks;
  for (auto* p = static_cast<const VkBaseInStructure*>(info->pNext); p != nullptr; p = p->pNext) {
    if (p->sType != VK_STRUCTURE_TYPE_RENDER_PASS_MULTIVIEW_CREATE_INFO) continue;
    const auto* multiview = reinterpret_cast<const VkRenderPassMultiviewCreateInfo*>(p);
    viewMasks.assign(multiview->pViewMasks, multiview->pViewMasks + multiview->subpassCount);
  }
  recordRenderPass(*dev, *pass, subpassColors(*info), std::move(viewMasks));
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateRenderPass2(VkDevice device, const VkRenderPassCreateInfo2* info,
                                                 const VkAllocationCallbacks* alloc, VkRenderPass* pass) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateRenderPass2(device, info, alloc, pass);
  if (result != VK_SUCCESS) return result;
  std::vector<uint32_t> viewMasks;
  for (uint32_t s = 0; s < info->subpassCount; ++s) viewMasks.push_back(info->pSubpasses[s].viewMask);
  recordRenderPass(*dev, *pass, subpassColors(*info), std::move(viewMasks));
  return result;
}

VKAPI_ATTR VkResult VKAPI_CALL CreateFramebuffer(VkDevice device, const VkFramebufferCreateInfo* info,
                                                 const VkAllocationCallbacks* alloc, VkFramebuffer* framebuffer) {
  DeviceState* dev = deviceOf(device);
  VkResult result = dev->d.CreateFramebuffer(device, info, alloc, framebuffer);
  if (result != VK_SUCCESS) return result;
  std::vector<uint64_t> views;
  if (!(info->flags & VK_FRAMEBUFFER_CREATE_IMAGELESS_BIT)) {
    for (uint32_t i = 0; i < info->attachmentCount; ++i) views.push_back(u64(info->pAttachments[i]));
  }
  std::lock_guard lock(dev->mutex);
  dev->framebuffers[u64(*framebuffer)] = std::move(views);
  return result;
}

}  // namespace

PFN_vkVoidFunction interceptedResources(std::string_view name) {
  TALLY_INTERCEPT(CreateImage)
  TALLY_INTERCEPT(CreateBuffer)
  TALLY_INTERCEPT(CreateImageView)
  TALLY_INTERCEPT(CreateBufferView)
  TALLY_INTERCEPT(DestroyImage)
  TALLY_INTERCEPT(DestroyBuffer)
  TALLY_INTERCEPT(DestroyImageView)
  TALLY_INTERCEPT(DestroyBufferView)
  TALLY_INTERCEPT(DestroyFramebuffer)
  TALLY_INTERCEPT(SetDebugUtilsObjectNameEXT)
  TALLY_INTERCEPT(CreateSwapchainKHR)
  TALLY_INTERCEPT(GetSwapchainImagesKHR)
  TALLY_INTERCEPT(CreateRenderPass)
  TALLY_INTERCEPT(CreateRenderPass2)
  TALLY_INTERCEPT_ALIAS(CreateRenderPass2KHR, CreateRenderPass2)
  TALLY_INTERCEPT(CreateFramebuffer)
  return nullptr;
}

}  // namespace tally::layer
