// The scene's GPU images (GpuScene's textures, map arrays and sky): mip
// chains built by blits or taken from the file, nearest resizing for the map
// arrays, and the sky cube's texels.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "renderers/gpu_scene.hpp"

namespace tally::renderers {

// Levels of a full mip chain down to 1x1.
uint32_t mipLevels(uint32_t width, uint32_t height);

// A device-local image (view type 2D, 2D array or cube) with `levels` mips and
// `layers` layers, sampled and a transfer source and destination.
MipImage createMipImage(const gpu::Context& ctx, uint32_t width, uint32_t height, uint32_t levels,
                        uint32_t layers, VkFormat format, VkImageViewType viewType);
void destroyMipImage(const gpu::Context& ctx, MipImage& image);

// Uploads level 0 of every layer (tightly packed RGBA8, layer after layer),
// blits the mip chain down (box filter by linear blits) and leaves the image
// in SHADER_READ_ONLY_OPTIMAL.
void uploadWithMips(const gpu::Context& ctx, const MipImage& image, std::span<const uint8_t> texels);

// Replaces levels 1.. of `layer` with a texture's own (scenes::Texture::mips,
// checked by explicitMipsError) after uploadWithMips; leaves the image in
// SHADER_READ_ONLY_OPTIMAL.
void uploadExplicitMips(const gpu::Context& ctx, const MipImage& image, uint32_t layer,
                        const std::vector<std::vector<uint8_t>>& mips);

// Why a texture's explicit mips do not fit its size ("" when they do or it has none).
std::string explicitMipsError(const scenes::Texture& t);

// Nearest-texel resize (only glTF scenes whose maps of one kind differ in size need it).
std::vector<uint8_t> resizeNearest(const scenes::Texture& t, uint32_t width, uint32_t height);

// The sky cube's six kSkyFaceSize^2 faces, RGBA8, in Vulkan face order.
std::vector<uint8_t> skyTexels();

}  // namespace tally::renderers
