#include "gpu/footprint.hpp"

#include <algorithm>
#include <cstring>
#include <stdexcept>

namespace tally::gpu {

namespace fp = spirv::footprint;

uint32_t samplerBits(VkFilter magFilter, VkFilter minFilter, VkSamplerMipmapMode mipmapMode,
                     VkSamplerAddressMode addressU, VkSamplerAddressMode addressV) {
  uint32_t bits = 0;
  if (magFilter == VK_FILTER_LINEAR) bits |= fp::kMagLinear;
  if (minFilter == VK_FILTER_LINEAR) bits |= fp::kMinLinear;
  if (mipmapMode == VK_SAMPLER_MIPMAP_MODE_LINEAR) bits |= fp::kMipLinear;
  bits |= (static_cast<uint32_t>(addressU) & 7u) << fp::kAddressUShift;
  bits |= (static_cast<uint32_t>(addressV) & 7u) << fp::kAddressVShift;
  return bits;
}

uint32_t samplerBits(const VkSamplerCreateInfo& info) {
  return samplerBits(info.magFilter, info.minFilter, info.mipmapMode, info.addressModeU, info.addressModeV);
}

FootprintTable::~FootprintTable() { destroy(); }

void FootprintTable::configure(uint32_t blockBytes, uint32_t slots) {
  if (!fp::validBlockBytes(blockBytes)) throw std::invalid_argument("footprint block size must be 32, 64 or 128");
  blockBytes_ = blockBytes;
  slots_ = std::max(slots, 1u);
  entries_.clear();
  regions_.clear();
  words_ = 0;
}

uint32_t FootprintTable::region(const std::string& key, uint64_t blocks) {
  if (auto it = regions_.find(key); it != regions_.end()) return it->second.base;
  uint64_t words = fp::bitmapWords(blocks);
  if (uint64_t(words_) + words > 0x40000000u) throw std::runtime_error("footprint bitmaps over 4 GiB");
  Region r{words_, blocks};
  words_ += static_cast<uint32_t>(words);
  regions_.emplace(key, r);
  return r.base;
}

uint32_t FootprintTable::addBank() {
  uint32_t bank = banks();
  entries_.resize(entries_.size() + slots_, fp::Entry{});
  return bank;
}

void FootprintTable::set(uint32_t bank, uint32_t slot, const fp::Entry& entry) {
  if (slot >= slots_ || bank >= banks()) throw std::out_of_range("footprint table: slot or bank out of range");
  entries_[size_t(bank) * slots_ + slot] = entry;
}

void FootprintTable::create(const Context& ctx) {
  destroy();
  ctx_ = &ctx;
  if (entries_.empty()) addBank();
  const uint32_t entryBytes = fp::kEntryWords * 4;
  const uint32_t align = std::max<uint32_t>(uint32_t(ctx.limits.minStorageBufferOffsetAlignment), 4);
  bankStride_ = (slots_ * entryBytes + align - 1) / align * align;
  std::vector<uint8_t> bytes(size_t(bankStride_) * banks(), 0);
  for (uint32_t b = 0; b < banks(); ++b) {
    std::memcpy(bytes.data() + size_t(b) * bankStride_, entries_.data() + size_t(b) * slots_,
                size_t(slots_) * entryBytes);
  }
  table_ = createBuffer(ctx, bytes.size(), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                        MemoryUse::DeviceLocal);
  uploadBuffer(ctx, table_, bytes);
  bitmaps_ = createBuffer(ctx, VkDeviceSize(std::max(words_, 1u)) * 4,
                          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                          MemoryUse::DeviceLocal);
}

void FootprintTable::destroy() {
  if (ctx_ == nullptr) return;
  destroyBuffer(*ctx_, table_);
  destroyBuffer(*ctx_, bitmaps_);
  ctx_ = nullptr;
}

std::array<DescriptorWrite, 2> FootprintTable::descriptorWrites(uint32_t tableBinding, uint32_t bitmapBinding) const {
  std::array<DescriptorWrite, 2> w;
  w[0].binding = tableBinding;
  w[0].type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER_DYNAMIC;
  w[0].buffer = tableInfo();
  w[1].binding = bitmapBinding;
  w[1].type = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  w[1].buffer = bitmapInfo();
  return w;
}

void FootprintTable::recordClear(VkCommandBuffer cmd) const {
  vkCmdFillBuffer(cmd, bitmaps_.buffer, 0, VK_WHOLE_SIZE, 0);
  VkMemoryBarrier barrier = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  barrier.dstAccessMask = VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT;
  vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, 1, &barrier, 0,
                       nullptr, 0, nullptr);
}

std::vector<uint32_t> FootprintTable::read() const {
  auto bytes = readBuffer(*ctx_, bitmaps_, 0, VkDeviceSize(std::max(words_, 1u)) * 4);
  std::vector<uint32_t> words(bytes.size() / 4);
  std::memcpy(words.data(), bytes.data(), words.size() * 4);
  return words;
}

uint64_t FootprintTable::blocks(const std::vector<uint32_t>& bitmap, const std::string& key) const {
  auto it = regions_.find(key);
  if (it == regions_.end()) return 0;
  return fp::countBlocks(bitmap, it->second.base, it->second.blocks);
}

}  // namespace tally::gpu
