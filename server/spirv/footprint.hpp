// Footprint: which blocks of each resource the accesses of a pass touched.
// The instrumentation (inject.cpp) marks, for every access, the block or
// blocks it covers in a per-resource bitmap; the reader counts the bits. The
// shader learns where a slot's bitmap lies, and the geometry of what is
// bound there, from a table the host fills: one Entry of kEntryWords u32 per
// counter slot (docs/measurement.md, "Footprint").
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "common/result.hpp"

namespace tally::spirv::footprint {

constexpr uint32_t kEntryWords = 32;  // one 128-byte table entry per counter slot
constexpr uint32_t kMaxLevels = 16;   // mip levels an entry describes (32768 texels a side)

// Word offsets within an entry.
enum Word : uint32_t {
  kKind = 0,         // EntryKind
  kBase = 1,         // first word of the slot's bitmap in the bitmap buffer
  kCapacity = 2,     // blocks the bitmap covers; block `capacity` is a scratch bit that is never counted
  kTexelBytes = 3,   // images: bytes per texel (x samples); vertex inputs: the binding's stride
  kWidth = 4,        // images: level 0 of the image; vertex inputs: the attribute's offset
  kHeight = 5,
  kLevels = 6,       // levels of the bound view
  kLayers = 7,       // layers of the bound view
  kTileWidth = 8,    // texels a block covers, as a 2D tile
  kTileHeight = 9,
  kSampler = 10,     // Sampler bits of the bound sampler (sampled reads)
  kBaseLevel = 11,   // the view's first level within the image
  kLayerBlocks = 12, // blocks of one layer, all levels
  kLevelStart = 16,  // kMaxLevels words: block of (level, layer 0), image levels from 0
};

enum class EntryKind : uint32_t {
  Off = 0,          // not measured: the shader skips the slot
  Buffer = 1,       // byte ranges of a buffer
  VertexInput = 2,  // a vertex attribute: vertex index x stride + offset, then as Buffer
  Image = 3,        // texels of an image (sampled, fetched, stored, or an attachment at the pixel)
};

// Sampler bits (kSampler).
constexpr uint32_t kMagLinear = 1u << 0;
constexpr uint32_t kMinLinear = 1u << 1;
constexpr uint32_t kMipLinear = 1u << 2;
constexpr uint32_t kAddressUShift = 4;  // VkSamplerAddressMode, 3 bits
constexpr uint32_t kAddressVShift = 8;
// VkSamplerAddressMode values.
constexpr uint32_t kRepeat = 0, kMirroredRepeat = 1, kClampToEdge = 2, kClampToBorder = 3, kMirrorClampToEdge = 4;

// Block sizes a capture may choose, and the default (docs/measurement.md).
constexpr uint32_t kDefaultBlockBytes = 64;
bool validBlockBytes(uint32_t bytes);  // 32, 64 or 128

// The 2D tile of texels one block holds: blockBytes / texelBytes texels,
// as square as powers of two allow (wider than tall). Texels larger than
// a block take one block each (tile 1 x 1).
struct Tile {
  uint32_t width = 1, height = 1;
};
Tile tileFor(uint32_t blockBytes, uint32_t texelBytes);

using Entry = std::array<uint32_t, kEntryWords>;

struct ImageGeometry {
  uint32_t width = 0, height = 0;  // level 0
  uint32_t levels = 1;             // of the image
  uint32_t layers = 1;
  uint32_t texelBytes = 0;         // x samples for multisampled images
  uint32_t baseLevel = 0;          // the bound view's first level
  uint32_t viewLevels = 0;         // the bound view's levels (0: to the last)
  uint32_t sampler = 0;            // Sampler bits; 0 for nearest, repeat
};

// Blocks an image's bitmap needs (every level and layer).
uint64_t imageBlocks(const ImageGeometry& image, uint32_t blockBytes);
// The entry of an image whose bitmap starts at word `base`.
Entry imageEntry(const ImageGeometry& image, uint32_t blockBytes, uint32_t base);
// Blocks of a buffer of `bytes`.
uint64_t bufferBlocks(uint64_t bytes, uint32_t blockBytes);
Entry bufferEntry(uint64_t bytes, uint32_t blockBytes, uint32_t base);
Entry vertexInputEntry(uint64_t bytes, uint32_t stride, uint32_t offset, uint32_t blockBytes, uint32_t base);
// Words of a bitmap of `blocks` blocks and its scratch bit.
uint32_t bitmapWords(uint64_t blocks);

// Set bits among the first `blocks` bits of the bitmap at word `base`.
uint64_t countBlocks(std::span<const uint32_t> bitmap, uint32_t base, uint64_t blocks);

}  // namespace tally::spirv::footprint
