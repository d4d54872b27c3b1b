// Buffer device addresses (docs/layer.md, "Buffer device addresses"): the
// address range of every buffer whose address the application took and
// whose memory is bound, so that a physical-storage-buffer access's bytes
// go to the buffer its address lies in. As the validation layer's
// GPU-assisted mode checks addresses: a sorted table of ranges
// (spirv/address_table.hpp), uploaded in the command stream before a
// submission when it changed, searched by the instrumented access. Each
// buffer in the table has a slot of the access's counters for as long as a
// readback may still count into it; beyond spirv::kAddressBuffers of them,
// the "other buffers" slot. state.hpp includes this header for the struct;
// the functions are in addresses.cpp.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <vulkan/vulkan.h>

#include "spirv/address_table.hpp"

namespace tally::layer {

struct DeviceState;

struct AddressBook {
  // The application enabled bufferDeviceAddress and the layer counts by
  // address (it needs shaderInt64, which it enables with its 64-bit counters).
  bool enabled = false;
  // The next layer's functions under each name the application may call
  // (core, KHR, EXT; core, KHR): each intercept calls down its own.
  std::array<PFN_vkGetBufferDeviceAddress, 3> getAddressBy{};
  std::array<PFN_vkBindBufferMemory2, 2> bindMemory2By{};
  PFN_vkCmdUpdateBuffer updateBuffer = nullptr;
  struct Tracked {
    uint64_t address = 0;  // 0: not taken yet
    uint64_t size = 0;
    bool bound = false;   // vkBindBufferMemory[2]
    uint64_t learnt = 0;  // when its range entered the table: earlier wins where ranges start together
    uint32_t slot = spirv::kAddressUnknownSlot;  // while in the table
  };
  std::map<uint64_t, Tracked> buffers;  // by buffer handle
  // Slot kAddressFirstBufferSlot + i counts for owners[i] (0: free).
  std::array<uint64_t, spirv::kAddressBuffers> owners{};
  // Slots of destroyed buffers and the first readback that cannot count
  // into them: freed once every earlier readback has been read.
  std::vector<std::pair<uint32_t, uint64_t>> retiring;
  uint64_t version = 1, uploaded = 0, nextLearnt = 0;
  VkBuffer table = VK_NULL_HANDLE;
  VkDeviceMemory tableMemory = VK_NULL_HANDLE;
  struct Upload {
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    VkCommandPool pool = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;
  };
  std::vector<Upload> uploads;  // in flight, or done and kept for the next one
};

// The binding of the counter set that holds the table (the layer does not use footprint's).
constexpr uint32_t kAddressTableBinding = 1;

// Bound::resource of the lines of an address in no known range and of
// buffers beyond those with slots of their own.
constexpr uint64_t kUnknownAddress = ~uint64_t(0) - 2;
constexpr uint64_t kOtherBuffers = ~uint64_t(0) - 3;

// vkCreateDevice: whether the application enabled buffer device addresses,
// and the functions the layer calls for them.
void enableAddresses(DeviceState& dev, const VkDeviceCreateInfo& info);
// setupCounting: the table's buffer, bound at binding `binding` of the
// counter set (written into `set`); false (with a note) where it cannot be made.
bool setupAddressTable(DeviceState& dev, VkDescriptorSet set, uint32_t binding);
void destroyAddressTable(DeviceState& dev);
// vkQueueSubmit[2], before the application's submission: the table, where
// it changed, copied in the command stream of `queue`. Under dev.mutex.
void uploadAddresses(DeviceState& dev, VkQueue queue);
// vkDestroyBuffer: its range leaves the table. Under dev.mutex.
void forgetAddress(DeviceState& dev, uint64_t buffer);
// A readback: the buffer that counts into slot `i` of a site by address
// (kUnknownAddress, kOtherBuffers, or a buffer handle).
uint64_t addressedResource(const DeviceState& dev, uint32_t i);
// The calls the layer answers for addresses, by name ("vkGetBufferDeviceAddress").
PFN_vkVoidFunction interceptedAddresses(std::string_view name);

}  // namespace tally::layer
