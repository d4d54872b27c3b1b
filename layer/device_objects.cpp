// The layer's own Vulkan objects: buffers in a memory type it chooses, its
// command pools and buffers, and the barriers its recordings need.
#include "device_objects.hpp"

namespace tally::layer {

uint32_t memoryType(const DeviceState& dev, uint32_t bits, VkMemoryPropertyFlags required,
                    VkMemoryPropertyFlags preferred) {
  uint32_t fallback = UINT32_MAX;
  for (uint32_t i = 0; i < dev.memory.memoryTypeCount; ++i) {
    const auto flags = dev.memory.memoryTypes[i].propertyFlags;
    if (!(bits & (1u << i)) || (flags & required) != required) continue;
    if ((flags & preferred) == preferred) return i;
    if (fallback == UINT32_MAX) fallback = i;
  }
  return fallback;
}

bool createBuffer(DeviceState& dev, VkDeviceSize size, VkBufferUsageFlags usage, VkMemoryPropertyFlags required,
                  VkMemoryPropertyFlags preferred, VkBuffer& buffer, VkDeviceMemory& memory) {
  VkBufferCreateInfo info = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  info.size = size;
  info.usage = usage;
  if (dev.d.CreateBuffer(dev.device, &info, nullptr, &buffer) != VK_SUCCESS) return false;
  VkMemoryRequirements req{};
  dev.d.GetBufferMemoryRequirements(dev.device, buffer, &req);
  VkMemoryAllocateInfo alloc = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  alloc.allocationSize = req.size;
  alloc.memoryTypeIndex = memoryType(dev, req.memoryTypeBits, required, preferred);
  // A buffer whose device address is taken needs memory allocated for it (descriptor buffers).
  VkMemoryAllocateFlagsInfo flags = {VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_FLAGS_INFO};
  flags.flags = VK_MEMORY_ALLOCATE_DEVICE_ADDRESS_BIT;
  if (usage & VK_BUFFER_USAGE_SHADER_DEVICE_ADDRESS_BIT) alloc.pNext = &flags;
  if (alloc.memoryTypeIndex == UINT32_MAX || dev.d.AllocateMemory(dev.device, &alloc, nullptr, &memory) != VK_SUCCESS) {
    dev.d.DestroyBuffer(dev.device, buffer, nullptr);
    buffer = VK_NULL_HANDLE;
    return false;
  }
  dev.d.BindBufferMemory(dev.device, buffer, memory, 0);
  return true;
}

VkCommandPool ownPool(DeviceState& dev, uint32_t family) {
  auto it = dev.ownPools.find(family);
  if (it != dev.ownPools.end()) return it->second;
  VkCommandPoolCreateInfo info = {VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  info.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  info.queueFamilyIndex = family;
  VkCommandPool pool = VK_NULL_HANDLE;
  dev.d.CreateCommandPool(dev.device, &info, nullptr, &pool);
  dev.ownPools[family] = pool;
  return pool;
}

VkCommandBuffer ownCommandBuffer(DeviceState& dev, VkCommandPool pool) {
  VkCommandBufferAllocateInfo info = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  info.commandPool = pool;
  info.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  info.commandBufferCount = 1;
  VkCommandBuffer cmd = VK_NULL_HANDLE;
  if (dev.d.AllocateCommandBuffers(dev.device, &info, &cmd) != VK_SUCCESS) return VK_NULL_HANDLE;
  // A command buffer the layer made itself carries no dispatch pointer until the loader sets it.
  if (dev.setLoaderData != nullptr) dev.setLoaderData(dev.device, cmd);
  return cmd;
}

void memoryBarrier(DeviceState& dev, VkCommandBuffer cmd, VkPipelineStageFlags src, VkAccessFlags srcAccess,
                   VkPipelineStageFlags dst, VkAccessFlags dstAccess) {
  VkMemoryBarrier barrier = {VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  barrier.srcAccessMask = srcAccess;
  barrier.dstAccessMask = dstAccess;
  dev.d.CmdPipelineBarrier(cmd, src, dst, 0, 1, &barrier, 0, nullptr, 0, nullptr);
}

}  // namespace tally::layer
