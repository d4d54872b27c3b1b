// The host side of footprint counting (spirv/footprint.hpp): the table the
// instrumented shaders read, in banks (one per set of bindings: a pass, or a
// draw whose bindings differ), and the bitmaps they mark, in regions (one
// per resource a pass touches, reads and writes apart). Each counted frame
// clears the bitmaps; the reader counts each region's bits.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "gpu/context.hpp"
#include "gpu/pipelines.hpp"
#include "gpu/resources.hpp"
#include "spirv/footprint.hpp"

namespace tally::gpu {

// Sampler bits (spirv::footprint::kSampler) of a sampler's filters and address modes.
uint32_t samplerBits(VkFilter magFilter, VkFilter minFilter, VkSamplerMipmapMode mipmapMode,
                     VkSamplerAddressMode addressU, VkSamplerAddressMode addressV);
uint32_t samplerBits(const VkSamplerCreateInfo& info);

class FootprintTable {
 public:
  FootprintTable() = default;
  FootprintTable(const FootprintTable&) = delete;
  FootprintTable& operator=(const FootprintTable&) = delete;
  ~FootprintTable();

  // Before create(): the block size, and the slots every bank holds.
  void configure(uint32_t blockBytes, uint32_t slots);
  uint32_t blockBytes() const { return blockBytes_; }

  // A bitmap region of `blocks` blocks for `key` (the same key: the same
  // region, which must then have the same size); returns its first word.
  uint32_t region(const std::string& key, uint64_t blocks);
  // A new bank (all slots Off); returns its index.
  uint32_t addBank();
  void set(uint32_t bank, uint32_t slot, const spirv::footprint::Entry& entry);
  uint32_t banks() const { return static_cast<uint32_t>(entries_.size() / std::max(slots_, 1u)); }

  // Allocates the buffers and uploads the table (after every bank is set).
  void create(const Context& ctx);
  void destroy();
  bool created() const { return table_.buffer != VK_NULL_HANDLE; }

  // The descriptors: the table as a dynamic storage buffer (one bank's
  // window; bankOffset(b) is the dynamic offset) and the bitmaps.
  VkDescriptorBufferInfo tableInfo() const { return {table_.buffer, 0, bankStride_}; }
  VkDescriptorBufferInfo bitmapInfo() const { return {bitmaps_.buffer, 0, VK_WHOLE_SIZE}; }
  uint32_t bankOffset(uint32_t bank) const { return bank * bankStride_; }
  // Both descriptors, for a set whose table and bitmap bindings are these.
  std::array<DescriptorWrite, 2> descriptorWrites(uint32_t tableBinding, uint32_t bitmapBinding) const;

  // Clears the bitmaps (transfer, then a barrier to every shader stage).
  void recordClear(VkCommandBuffer cmd) const;
  // The bitmaps after the frame.
  std::vector<uint32_t> read() const;
  // Blocks set in `key`'s region (0 for an unknown key), and its bytes.
  uint64_t blocks(const std::vector<uint32_t>& bitmap, const std::string& key) const;
  uint64_t bytes(const std::vector<uint32_t>& bitmap, const std::string& key) const {
    return blocks(bitmap, key) * blockBytes_;
  }
  uint64_t bitmapBytes() const { return uint64_t(words_) * 4; }

 private:
  struct Region {
    uint32_t base = 0;
    uint64_t blocks = 0;
  };
  const Context* ctx_ = nullptr;
  uint32_t blockBytes_ = spirv::footprint::kDefaultBlockBytes;
  uint32_t slots_ = 0;
  uint32_t bankStride_ = 0;
  uint32_t words_ = 0;
  std::map<std::string, Region> regions_;
  std::vector<spirv::footprint::Entry> entries_;  // banks x slots
  Buffer table_, bitmaps_;
};

}  // namespace tally::gpu
