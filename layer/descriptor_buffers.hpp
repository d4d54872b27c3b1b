// VK_EXT_descriptor_buffer: what the layer keeps to name the resource behind
// a descriptor the application wrote into a buffer of its own, with the
// Vulkan headers only (the unit tests link it without a device).
//
// A descriptor buffer holds opaque bytes the driver returned from
// vkGetDescriptorEXT. The layer remembers which bytes name which resource;
// at a submission it reads, through the application's own host mapping, the
// bytes at the address a draw's set offset and the layout's binding offset
// give, and looks them up. docs/layer.md, "Descriptor buffers".
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include <vulkan/vulkan.h>

namespace tally::layer {

// What a descriptor names: a buffer, or an image view's image, format and aspect.
struct DescriptorTarget {
  uint64_t resource = 0;
  VkFormat format = VK_FORMAT_UNDEFINED;
  VkImageAspectFlags aspect = 0;
  bool operator==(const DescriptorTarget&) const = default;
};

// Descriptor bytes of a type -> what they name. By type, because a driver's
// descriptors may be small handles (NVIDIA's images are 4 bytes) that
// repeat across types. Bounded: an application that makes a descriptor per
// transient buffer range would otherwise grow it without end; past the
// bound the oldest are forgotten (their lines fall back to "set S binding
// B", with a note).
class DescriptorCatalog {
 public:
  static constexpr size_t kMaxDescriptors = 1u << 18;
  void remember(VkDescriptorType type, const void* bytes, size_t size, const DescriptorTarget& target);
  // The descriptor of `type` starting at `bytes`, `available` of them
  // readable, by the sizes vkGetDescriptorEXT was asked for with that type
  // (the longest first).
  std::optional<DescriptorTarget> lookup(VkDescriptorType type, const uint8_t* bytes, size_t available) const;
  size_t size() const { return named_.size(); }
  bool forgotSome() const { return forgot_; }

 private:
  std::unordered_map<std::string, DescriptorTarget> named_;
  std::deque<std::string> order_;
  std::map<VkDescriptorType, std::map<size_t, size_t, std::greater<>>> sizes_;  // type -> size -> descriptors of it
  bool forgot_ = false;
};

// A buffer whose device address the layer took, where its memory lies.
struct BufferPlace {
  uint64_t buffer = 0;
  VkDeviceSize size = 0;
  VkDeviceMemory memory = VK_NULL_HANDLE;
  VkDeviceSize memoryOffset = 0;
};

// Device addresses -> buffers, and memory -> the application's host mapping.
class AddressPlaces {
 public:
  void add(VkDeviceAddress address, const BufferPlace& place);
  void remove(uint64_t buffer);
  // The buffer whose range holds `address` (the latest bound where buffers alias), with its start.
  std::optional<std::pair<VkDeviceAddress, BufferPlace>> find(VkDeviceAddress address) const;
  void mapped(VkDeviceMemory memory, VkDeviceSize offset, VkDeviceSize size, void* host);
  void unmapped(VkDeviceMemory memory) { maps_.erase(memory); }
  void freed(VkDeviceMemory memory);
  // The host pointer to the bytes at `address` and how many may be read
  // there (within both the buffer and the mapping); null when the buffer is
  // unknown or its memory is not mapped.
  const uint8_t* host(VkDeviceAddress address, size_t& available) const;

 private:
  struct Mapping {
    VkDeviceSize offset = 0, size = 0;
    uint8_t* host = nullptr;
  };
  std::map<VkDeviceAddress, BufferPlace> starts_;
  std::unordered_map<uint64_t, VkDeviceAddress> byBuffer_;
  std::unordered_map<VkDeviceMemory, Mapping> maps_;
};

// A descriptor-buffer set layout's bindings, from vkGetDescriptorSetLayoutBindingOffsetEXT.
struct DescriptorBinding {
  VkDeviceSize offset = 0;
  VkDescriptorType type = VK_DESCRIPTOR_TYPE_MAX_ENUM;
  uint32_t count = 0;
};
using DescriptorSetLayoutOffsets = std::map<uint32_t, DescriptorBinding>;

// The size of one descriptor of `type` in a buffer: the size the application
// last asked vkGetDescriptorEXT for with that type, else the device's
// property (robust sizes apply where robustBufferAccess is on).
VkDeviceSize descriptorSize(const VkPhysicalDeviceDescriptorBufferPropertiesEXT& props, bool robust,
                            const std::map<VkDescriptorType, size_t>& seen, VkDescriptorType type);

// Where element `element` of a binding lies: the bound buffer's address plus
// the set's offset (vkCmdSetDescriptorBufferOffsetsEXT), the binding's offset
// and the element's place; none when the buffer index is not bound.
std::optional<VkDeviceAddress> descriptorAddress(const std::vector<VkDeviceAddress>& buffers, uint32_t bufferIndex,
                                                 VkDeviceSize setOffset, const DescriptorBinding& binding,
                                                 uint32_t element, VkDeviceSize size);

// Whether the layer may append its own descriptor buffer to `appBuffers`
// bound ones of which `appResource` hold resource descriptors.
bool roomForCounterBuffer(const VkPhysicalDeviceDescriptorBufferPropertiesEXT& props, uint32_t appBuffers,
                          uint32_t appResource);

}  // namespace tally::layer
