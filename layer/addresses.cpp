// Buffer device addresses: the ranges the application's buffers occupy, the
// table the instrumented accesses search, and its upload (addresses.hpp).
#include "addresses.hpp"

#include <algorithm>
#include <cstring>

#include "descriptor_buffers_layer.hpp"
#include "device_objects.hpp"
#include "intercepts.hpp"
#include "state.hpp"

namespace tally::layer {

namespace {

// vkCmdUpdateBuffer takes at most 64 KiB a call.
constexpr VkDeviceSize kUpdateChunk = 65536;

bool bufferDeviceAddressEnabled(const VkDeviceCreateInfo& info) {
  for (auto* p = static_cast<const VkBaseInStructure*>(info.pNext); p != nullptr; p = p->pNext) {
    switch (p->sType) {
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_VULKAN_1_2_FEATURES:
        if (reinterpret_cast<const VkPhysicalDeviceVulkan12Features*>(p)->bufferDeviceAddress) return true;
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES:
        if (reinterpret_cast<const VkPhysicalDeviceBufferDeviceAddressFeatures*>(p)->bufferDeviceAddress)
          return true;
        break;
      case VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_BUFFER_DEVICE_ADDRESS_FEATURES_EXT:
        if (reinterpret_cast<const VkPhysicalDeviceBufferDeviceAddressFeaturesEXT*>(p)->bufferDeviceAddress) {
          return true;
        }
        break;
      default: break;
    }
  }
  return false;
}

// The oldest readback still to be read: a slot retired at serial s is free
// once no readback before s is pending (lifetimes.cpp's rule for resources).
uint64_t oldestPending(const DeviceState& dev) {
  uint64_t oldest = dev.nextHarvest;
  for (const auto& h : dev.pending) oldest = std::min(oldest, h->serial);
  return oldest;
}

uint32_t takeSlot(DeviceState& dev, uint64_t buffer) {
  auto& book = dev.addresses;
  const uint64_t oldest = oldestPending(dev);
  std::erase_if(book.retiring, [&](const std::pair<uint32_t, uint64_t>& r) {
    if (r.second > oldest) return false;
    book.owners[r.first - spirv::kAddressFirstBufferSlot] = 0;
    return true;
  });
  for (uint32_t i = 0; i < book.owners.size(); ++i) {
    const bool retiring = std::any_of(book.retiring.begin(), book.retiring.end(), [&](const auto& r) {
      return r.first == spirv::kAddressFirstBufferSlot + i;
    });
    if (book.owners[i] != 0 || retiring) continue;
    book.owners[i] = buffer;
    return spirv::kAddressFirstBufferSlot + i;
  }
  return spirv::kAddressOtherSlot;
}

// A buffer's address or binding became known: its range enters the table
// once both are.
void learn(DeviceState& dev, uint64_t buffer, uint64_t address, bool bound) {
  auto& book = dev.addresses;
  AddressBook::Tracked& t = book.buffers[buffer];
  const bool before = t.address != 0 && t.bound;
  if (address != 0) t.address = address;
  t.bound = t.bound || bound;
  if (before || t.address == 0 || !t.bound) return;
  auto r = dev.resources.find(buffer);
  t.size = r != dev.resources.end() ? r->second.size : 0;
  t.learnt = book.nextLearnt++;
  t.slot = takeSlot(dev, buffer);
  ++book.version;
}

// vkGetBufferDeviceAddress, its KHR and EXT names: each calls down its own.
template <size_t Which>
VKAPI_ATTR VkDeviceAddress VKAPI_CALL GetBufferDeviceAddress(VkDevice device,
                                                             const VkBufferDeviceAddressInfo* info) {
  DeviceState* dev = deviceOf(device);
  const VkDeviceAddress address = dev->addresses.getAddressBy[Which](device, info);
  if (address != 0 && dev->addresses.enabled) {
    std::lock_guard lock(dev->mutex);
    learn(*dev, u64(info->buffer), address, false);
  }
  return address;
}

VKAPI_ATTR VkResult VKAPI_CALL BindBufferMemory(VkDevice device, VkBuffer buffer, VkDeviceMemory memory,
                                                VkDeviceSize offset) {
  DeviceState* dev = deviceOf(device);
  const VkResult result = dev->d.BindBufferMemory(device, buffer, memory, offset);
  if (result == VK_SUCCESS) {
    std::lock_guard lock(dev->mutex);
    if (dev->addresses.enabled) learn(*dev, u64(buffer), 0, true);
    // Descriptor buffers read descriptors through the memory a buffer is bound to.
    noteBufferMemory(*dev, buffer, memory, offset);
  }
  return result;
}

template <size_t Which>
VKAPI_ATTR VkResult VKAPI_CALL BindBufferMemory2(VkDevice device, uint32_t count,
                                                 const VkBindBufferMemoryInfo* infos) {
  DeviceState* dev = deviceOf(device);
  const VkResult result = dev->addresses.bindMemory2By[Which](device, count, infos);
  if (result == VK_SUCCESS) {
    std::lock_guard lock(dev->mutex);
    for (uint32_t i = 0; i < count; ++i) {
      if (dev->addresses.enabled) learn(*dev, u64(infos[i].buffer), 0, true);
      noteBufferMemory(*dev, infos[i].buffer, infos[i].memory, infos[i].memoryOffset);
    }
  }
  return result;
}

}  // namespace

void enableAddresses(DeviceState& dev, const VkDeviceCreateInfo& info) {
  auto& book = dev.addresses;
  auto load = [&](const char* name) { return dev.d.GetDeviceProcAddr(dev.device, name); };
  const char* addressNames[] = {"vkGetBufferDeviceAddress", "vkGetBufferDeviceAddressKHR",
                                "vkGetBufferDeviceAddressEXT"};
  for (size_t i = 0; i < book.getAddressBy.size(); ++i) {
    book.getAddressBy[i] = reinterpret_cast<PFN_vkGetBufferDeviceAddress>(load(addressNames[i]));
  }
  book.bindMemory2By[0] = reinterpret_cast<PFN_vkBindBufferMemory2>(load("vkBindBufferMemory2"));
  book.bindMemory2By[1] = reinterpret_cast<PFN_vkBindBufferMemory2>(load("vkBindBufferMemory2KHR"));
  book.updateBuffer = reinterpret_cast<PFN_vkCmdUpdateBuffer>(load("vkCmdUpdateBuffer"));
  if (dev.config.output.empty() || !dev.config.error.empty() || !bufferDeviceAddressEnabled(info)) return;
  if (!dev.int64Atomics) {
    dev.notes.insert(
        "buffer device address: accesses are counted per access width, not by buffer: the layer "
        "could not enable 64-bit integers and atomics (shaderInt64, shaderBufferInt64Atomics)");
    return;
  }
  book.enabled = book.updateBuffer != nullptr;
}

bool setupAddressTable(DeviceState& dev, VkDescriptorSet set, uint32_t binding) {
  auto& book = dev.addresses;
  if (!book.enabled) return true;
  if (!createBuffer(dev, spirv::addressTableBytes(spirv::kAddressSegments),
                    VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, 0,
                    VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, book.table, book.tableMemory)) {
    book.enabled = false;
    dev.notes.insert(
        "buffer device address: accesses are counted per access width, not by buffer: the layer "
        "could not allocate its address table");
    return false;
  }
  VkDescriptorBufferInfo bufferInfo = {book.table, 0, VK_WHOLE_SIZE};
  VkWriteDescriptorSet write = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
  write.dstSet = set;
  write.dstBinding = binding;
  write.descriptorCount = 1;
  write.descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
  write.pBufferInfo = &bufferInfo;
  dev.d.UpdateDescriptorSets(dev.device, 1, &write, 0, nullptr);
  return true;
}

void destroyAddressTable(DeviceState& dev) {
  auto& book = dev.addresses;
  for (const auto& up : book.uploads) {
    dev.d.FreeCommandBuffers(dev.device, up.pool, 1, &up.cmd);
    dev.d.DestroyFence(dev.device, up.fence, nullptr);
  }
  book.uploads.clear();
  if (book.table != VK_NULL_HANDLE) dev.d.DestroyBuffer(dev.device, book.table, nullptr);
  if (book.tableMemory != VK_NULL_HANDLE) dev.d.FreeMemory(dev.device, book.tableMemory, nullptr);
  book.table = VK_NULL_HANDLE;
  book.tableMemory = VK_NULL_HANDLE;
}

namespace {

// A command buffer of the queue's family whose last upload has finished, or a new one.
AddressBook::Upload* freeUpload(DeviceState& dev, VkCommandPool pool) {
  auto& book = dev.addresses;
  for (auto& up : book.uploads) {
    if (up.pool != pool || dev.d.GetFenceStatus(dev.device, up.fence) != VK_SUCCESS) continue;
    dev.d.ResetFences(dev.device, 1, &up.fence);
    return &up;
  }
  AddressBook::Upload up;
  up.pool = pool;
  up.cmd = ownCommandBuffer(dev, pool);
  VkFenceCreateInfo fence = {VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  if (up.cmd == VK_NULL_HANDLE || dev.d.CreateFence(dev.device, &fence, nullptr, &up.fence) != VK_SUCCESS) {
    if (up.cmd != VK_NULL_HANDLE) dev.d.FreeCommandBuffers(dev.device, pool, 1, &up.cmd);
    return nullptr;
  }
  book.uploads.push_back(up);
  return &book.uploads.back();
}

}  // namespace

void uploadAddresses(DeviceState& dev, VkQueue queue) {
  auto& book = dev.addresses;
  // Outside the window nothing searches the table: the application's submissions go alone.
  if (!dev.counting || book.table == VK_NULL_HANDLE || book.version == book.uploaded || !windowAhead(dev))
    return;
  auto family = dev.queueFamilies.find(queue);
  if (family == dev.queueFamilies.end()) return;
  std::vector<std::pair<uint64_t, spirv::AddressRange>> learnt;
  for (const auto& [buffer, t] : book.buffers) {
    if (t.address != 0 && t.bound) learnt.push_back({t.learnt, {t.address, t.address + t.size, t.slot}});
  }
  std::sort(learnt.begin(), learnt.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<spirv::AddressRange> ranges;
  for (const auto& [order, range] : learnt) ranges.push_back(range);
  const spirv::AddressTable table = spirv::buildAddressTable(ranges);
  if (table.dropped != 0) {
    dev.notes.insert("buffer device address: more buffer ranges than the address table's " +
                     std::to_string(spirv::kAddressSegments) +
                     " segments; accesses to the rest count as unknown address");
  }
  AddressBook::Upload* up = freeUpload(dev, ownPool(dev, family->second));
  if (up == nullptr) return;
  // In the queue's own order: after every earlier submission's reads of the
  // table, before any later one's. The application's work never waits on the host.
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  dev.d.BeginCommandBuffer(up->cmd, &begin);
  memoryBarrier(dev, up->cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, 0, VK_PIPELINE_STAGE_TRANSFER_BIT,
                VK_ACCESS_TRANSFER_WRITE_BIT);
  const auto* bytes = reinterpret_cast<const uint8_t*>(table.words.data());
  const VkDeviceSize size = table.words.size() * sizeof(uint64_t);
  for (VkDeviceSize at = 0; at < size; at += kUpdateChunk) {
    book.updateBuffer(up->cmd, book.table, at, std::min(kUpdateChunk, size - at), bytes + at);
  }
  memoryBarrier(dev, up->cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT,
                VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_ACCESS_SHADER_READ_BIT);
  dev.d.EndCommandBuffer(up->cmd);
  VkSubmitInfo submit = {VK_STRUCTURE_TYPE_SUBMIT_INFO};
  submit.commandBufferCount = 1;
  submit.pCommandBuffers = &up->cmd;
  if (dev.d.QueueSubmit(queue, 1, &submit, up->fence) == VK_SUCCESS) book.uploaded = book.version;
}

void forgetAddress(DeviceState& dev, uint64_t buffer) {
  auto& book = dev.addresses;
  auto it = book.buffers.find(buffer);
  if (it == book.buffers.end()) return;
  if (it->second.address != 0 && it->second.bound) {
    ++book.version;
    if (it->second.slot >= spirv::kAddressFirstBufferSlot)
      book.retiring.push_back({it->second.slot, dev.nextHarvest});
  }
  book.buffers.erase(it);
}

uint64_t addressedResource(const DeviceState& dev, uint32_t i) {
  if (i == spirv::kAddressOtherSlot) return kOtherBuffers;
  if (i < spirv::kAddressFirstBufferSlot || i >= spirv::kAddressSlots) return kUnknownAddress;
  const uint64_t owner = dev.addresses.owners[i - spirv::kAddressFirstBufferSlot];
  return owner != 0 ? owner : kUnknownAddress;
}

PFN_vkVoidFunction interceptedAddresses(std::string_view name) {
  TALLY_INTERCEPT_ALIAS(GetBufferDeviceAddress, GetBufferDeviceAddress<0>)
  TALLY_INTERCEPT_ALIAS(GetBufferDeviceAddressKHR, GetBufferDeviceAddress<1>)
  TALLY_INTERCEPT_ALIAS(GetBufferDeviceAddressEXT, GetBufferDeviceAddress<2>)
  TALLY_INTERCEPT(BindBufferMemory)
  TALLY_INTERCEPT_ALIAS(BindBufferMemory2, BindBufferMemory2<0>)
  TALLY_INTERCEPT_ALIAS(BindBufferMemory2KHR, BindBufferMemory2<1>)
  return nullptr;
}

}  // namespace tally::layer
