#include "spirv/footprint.hpp"

#include <algorithm>
#include <bit>

namespace tally::spirv::footprint {

bool validBlockBytes(uint32_t bytes) { return bytes == 32 || bytes == 64 || bytes == 128; }

Tile tileFor(uint32_t blockBytes, uint32_t texelBytes) {
  if (texelBytes == 0 || texelBytes >= blockBytes) return {};
  uint32_t texels = std::bit_floor(blockBytes / texelBytes);
  uint32_t log2 = std::countr_zero(texels);
  Tile t;
  t.width = 1u << ((log2 + 1) / 2);
  t.height = texels / t.width;
  return t;
}

namespace {

uint32_t levelBlocks(const ImageGeometry& image, const Tile& tile, uint32_t level) {
  uint32_t w = std::max(image.width >> level, 1u), h = std::max(image.height >> level, 1u);
  return ((w + tile.width - 1) / tile.width) * ((h + tile.height - 1) / tile.height);
}

}  // namespace

uint64_t imageBlocks(const ImageGeometry& image, uint32_t blockBytes) {
  Tile tile = tileFor(blockBytes, image.texelBytes);
  uint64_t layer = 0;
  for (uint32_t l = 0; l < std::min(image.levels, kMaxLevels); ++l) layer += levelBlocks(image, tile, l);
  return layer * std::max(image.layers, 1u);
}

Entry imageEntry(const ImageGeometry& image, uint32_t blockBytes, uint32_t base) {
  Entry e{};
  Tile tile = tileFor(blockBytes, image.texelBytes);
  e[kKind] = static_cast<uint32_t>(EntryKind::Image);
  e[kBase] = base;
  e[kCapacity] = static_cast<uint32_t>(imageBlocks(image, blockBytes));
  e[kTexelBytes] = image.texelBytes;
  e[kWidth] = image.width;
  e[kHeight] = image.height;
  uint32_t levels = std::min(image.levels, kMaxLevels);
  uint32_t base0 = std::min(image.baseLevel, levels - 1);
  e[kLevels] = image.viewLevels == 0 ? levels - base0 : std::min(image.viewLevels, levels - base0);
  e[kLayers] = std::max(image.layers, 1u);
  e[kTileWidth] = tile.width;
  e[kTileHeight] = tile.height;
  e[kSampler] = image.sampler;
  e[kBaseLevel] = base0;
  uint32_t start = 0;
  for (uint32_t l = 0; l < levels; ++l) {
    e[kLevelStart + l] = start;
    start += levelBlocks(image, tile, l);
  }
  e[kLayerBlocks] = start;
  return e;
}

uint64_t bufferBlocks(uint64_t bytes, uint32_t blockBytes) { return (bytes + blockBytes - 1) / blockBytes; }

Entry bufferEntry(uint64_t bytes, uint32_t blockBytes, uint32_t base) {
  Entry e{};
  e[kKind] = static_cast<uint32_t>(EntryKind::Buffer);
  e[kBase] = base;
  e[kCapacity] = static_cast<uint32_t>(bufferBlocks(bytes, blockBytes));
  return e;
}

Entry vertexInputEntry(uint64_t bytes, uint32_t stride, uint32_t offset, uint32_t blockBytes, uint32_t base) {
  Entry e = bufferEntry(bytes, blockBytes, base);
  e[kKind] = static_cast<uint32_t>(EntryKind::VertexInput);
  e[kTexelBytes] = stride;
  e[kWidth] = offset;
  return e;
}

uint32_t bitmapWords(uint64_t blocks) { return static_cast<uint32_t>((blocks + 1 + 31) / 32); }

uint64_t countBlocks(std::span<const uint32_t> bitmap, uint32_t base, uint64_t blocks) {
  uint64_t n = 0;
  uint64_t full = blocks / 32;
  for (uint64_t w = 0; w < full && base + w < bitmap.size(); ++w) n += std::popcount(bitmap[base + w]);
  if (uint32_t rest = blocks % 32; rest != 0 && base + full < bitmap.size()) {
    n += std::popcount(bitmap[base + full] & ((1u << rest) - 1));
  }
  return n;
}

}  // namespace tally::spirv::footprint
