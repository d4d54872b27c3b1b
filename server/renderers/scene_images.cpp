// The scene's GPU images: mip chains built by blits or taken from the file,
// resized layers for the map arrays, and the sky cube's texels.
#include "renderers/scene_images.hpp"

#include <algorithm>
#include <cstring>

#include "gpu/resources.hpp"
#include "gpu/vk_check.hpp"

namespace tally::renderers {
namespace {

void barrier(VkCommandBuffer cmd, VkImage image, uint32_t level, uint32_t levelCount, uint32_t layers,
             VkImageLayout from, VkImageLayout to) {
  VkImageMemoryBarrier b = {VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
  b.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
  b.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
  b.oldLayout = from;
  b.newLayout = to;
  b.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  b.image = image;
  b.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, level, levelCount, 0, layers};
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 0,
                       nullptr, 0, nullptr, 1, &b);
}

// The sky: a vertical gradient from a warm horizon to a blue zenith, darker below.
std::array<uint8_t, 4> skyTexel(glm::vec3 d) {
  d = glm::normalize(d);
  float up = d.y;
  glm::vec3 horizon(0.85f, 0.80f, 0.70f), zenith(0.25f, 0.45f, 0.85f), ground(0.30f, 0.28f, 0.25f);
  glm::vec3 c =
      up >= 0 ? glm::mix(horizon, zenith, std::sqrt(up)) : glm::mix(horizon, ground, std::sqrt(-up));
  return {uint8_t(c.r * 255 + 0.5f), uint8_t(c.g * 255 + 0.5f), uint8_t(c.b * 255 + 0.5f), 255};
}

}  // namespace

uint32_t mipLevels(uint32_t width, uint32_t height) {
  uint32_t levels = 1;
  while ((width | height) >> levels) ++levels;
  return levels;
}

MipImage createMipImage(const gpu::Context& ctx, uint32_t width, uint32_t height, uint32_t levels,
                        uint32_t layers, VkFormat format, VkImageViewType viewType) {
  const bool cube = viewType == VK_IMAGE_VIEW_TYPE_CUBE;
  MipImage result;
  result.format = format;
  result.width = width;
  result.height = height;
  result.levels = levels;
  result.layers = layers;
  VkImageCreateInfo info = {VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  info.flags = cube ? VK_IMAGE_CREATE_CUBE_COMPATIBLE_BIT : 0;
  info.imageType = VK_IMAGE_TYPE_2D;
  info.format = format;
  info.extent = {width, height, 1};
  info.mipLevels = levels;
  info.arrayLayers = layers;
  info.samples = VK_SAMPLE_COUNT_1_BIT;
  info.tiling = VK_IMAGE_TILING_OPTIMAL;
  info.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VK_CHECK(vkCreateImage(ctx.device, &info, nullptr, &result.image));
  VkMemoryRequirements requirements;
  vkGetImageMemoryRequirements(ctx.device, result.image, &requirements);
  VkMemoryAllocateInfo allocate = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  allocate.allocationSize = requirements.size;
  allocate.memoryTypeIndex = gpu::selectMemoryType(ctx.memoryProperties, requirements.memoryTypeBits,
                                                   VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  VK_CHECK(vkAllocateMemory(ctx.device, &allocate, nullptr, &result.memory));
  VK_CHECK(vkBindImageMemory(ctx.device, result.image, result.memory, 0));
  result.allocationBytes = requirements.size;
  VkImageViewCreateInfo view = {VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO};
  view.image = result.image;
  view.viewType = viewType;
  view.format = format;
  view.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, levels, 0, layers};
  VK_CHECK(vkCreateImageView(ctx.device, &view, nullptr, &result.view));
  ctx.log->view(result.view, info, view);
  return result;
}

void destroyMipImage(const gpu::Context& ctx, MipImage& image) {
  if (image.view != VK_NULL_HANDLE) vkDestroyImageView(ctx.device, image.view, nullptr);
  if (image.image != VK_NULL_HANDLE) vkDestroyImage(ctx.device, image.image, nullptr);
  if (image.memory != VK_NULL_HANDLE) vkFreeMemory(ctx.device, image.memory, nullptr);
  image = MipImage{};
}

void uploadWithMips(const gpu::Context& ctx, const MipImage& image, std::span<const uint8_t> texels) {
  gpu::submitFromStaging(ctx, texels, [&](VkCommandBuffer cmd, VkBuffer staging) {
    barrier(cmd, image.image, 0, image.levels, image.layers, VK_IMAGE_LAYOUT_UNDEFINED,
            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    VkBufferImageCopy copy = {};
    copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, image.layers};
    copy.imageExtent = {image.width, image.height, 1};
    vkCmdCopyBufferToImage(cmd, staging, image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &copy);
    int32_t w = int32_t(image.width), h = int32_t(image.height);
    for (uint32_t level = 1; level < image.levels; ++level) {
      barrier(cmd, image.image, level - 1, 1, image.layers, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
              VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
      VkImageBlit blit = {};
      blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level - 1, 0, image.layers};
      blit.srcOffsets[1] = {w, h, 1};
      w = std::max(w / 2, 1);
      h = std::max(h / 2, 1);
      blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, 0, image.layers};
      blit.dstOffsets[1] = {w, h, 1};
      vkCmdBlitImage(cmd, image.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, image.image,
                     VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
      barrier(cmd, image.image, level - 1, 1, image.layers, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
              VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
    }
    barrier(cmd, image.image, image.levels - 1, 1, image.layers, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
            VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  });
}

void uploadExplicitMips(const gpu::Context& ctx, const MipImage& image, uint32_t layer,
                        const std::vector<std::vector<uint8_t>>& mips) {
  std::vector<uint8_t> texels;
  std::vector<VkBufferImageCopy> copies;
  for (uint32_t i = 0; i < mips.size(); ++i) {
    const uint32_t level = i + 1;
    VkBufferImageCopy copy = {};
    copy.bufferOffset = texels.size();
    copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, level, layer, 1};
    copy.imageExtent = {std::max(image.width >> level, 1u), std::max(image.height >> level, 1u), 1};
    copies.push_back(copy);
    texels.insert(texels.end(), mips[i].begin(), mips[i].end());
  }
  gpu::submitFromStaging(ctx, texels, [&](VkCommandBuffer cmd, VkBuffer staging) {
    barrier(cmd, image.image, 1, image.levels - 1, image.layers, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL);
    vkCmdCopyBufferToImage(cmd, staging, image.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           uint32_t(copies.size()), copies.data());
    barrier(cmd, image.image, 1, image.levels - 1, image.layers, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
            VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL);
  });
}

std::string explicitMipsError(const scenes::Texture& t) {
  if (t.mips.empty()) return "";
  const uint32_t levels = mipLevels(t.width, t.height);
  if (t.mips.size() != levels - 1) {
    return "texture '" + t.name + "': mips has " + std::to_string(t.mips.size()) + " levels, a " +
           std::to_string(t.width) + "x" + std::to_string(t.height) + " texture has " +
           std::to_string(levels - 1) + " below level 0";
  }
  for (uint32_t level = 1; level < levels; ++level) {
    const size_t bytes = size_t(std::max(t.width >> level, 1u)) * std::max(t.height >> level, 1u) * 4;
    if (t.mips[level - 1].size() != bytes) {
      return "texture '" + t.name + "': mips[" + std::to_string(level - 1) + "] (level " +
             std::to_string(level) + ") has " + std::to_string(t.mips[level - 1].size()) + " bytes, expected " +
             std::to_string(bytes);
    }
  }
  return "";
}

std::vector<uint8_t> resizeNearest(const scenes::Texture& t, uint32_t width, uint32_t height) {
  if (t.width == width && t.height == height) return t.rgba8;
  std::vector<uint8_t> out(size_t(width) * height * 4);
  for (uint32_t y = 0; y < height; ++y) {
    uint32_t sy = uint32_t((uint64_t(y) * 2 + 1) * t.height / (2 * uint64_t(height)));
    for (uint32_t x = 0; x < width; ++x) {
      uint32_t sx = uint32_t((uint64_t(x) * 2 + 1) * t.width / (2 * uint64_t(width)));
      std::memcpy(&out[(size_t(y) * width + x) * 4], &t.rgba8[(size_t(sy) * t.width + sx) * 4], 4);
    }
  }
  return out;
}

std::vector<uint8_t> skyTexels() {
  const uint32_t n = kSkyFaceSize;
  std::vector<uint8_t> out(size_t(n) * n * 4 * 6);
  for (uint32_t face = 0; face < 6; ++face) {
    for (uint32_t y = 0; y < n; ++y) {
      for (uint32_t x = 0; x < n; ++x) {
        float u = (x + 0.5f) / n * 2 - 1, v = (y + 0.5f) / n * 2 - 1;
        glm::vec3 d;  // Vulkan cube face order +X -X +Y -Y +Z -Z (sc, tc per the spec table)
        switch (face) {
          case 0: d = {1, -v, -u}; break;
          case 1: d = {-1, -v, u}; break;
          case 2: d = {u, 1, v}; break;
          case 3: d = {u, -1, -v}; break;
          case 4: d = {u, -v, 1}; break;
          default: d = {-u, -v, -1}; break;
        }
        auto t = skyTexel(d);
        std::memcpy(&out[((size_t(face) * n + y) * n + x) * 4], t.data(), 4);
      }
    }
  }
  return out;
}

}  // namespace tally::renderers
