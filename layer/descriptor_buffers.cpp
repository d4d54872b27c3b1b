#include "descriptor_buffers.hpp"

#include <algorithm>

namespace tally::layer {

namespace {

// The catalog's key: the type's 4 bytes, then the descriptor's.
std::string key(VkDescriptorType type, const void* bytes, size_t size) {
  const int32_t t = int32_t(type);
  std::string k(reinterpret_cast<const char*>(&t), sizeof t);
  k.append(static_cast<const char*>(bytes), size);
  return k;
}

VkDescriptorType typeOf(const std::string& key) {
  int32_t t = 0;
  key.copy(reinterpret_cast<char*>(&t), sizeof t);
  return VkDescriptorType(t);
}

}  // namespace

void DescriptorCatalog::remember(VkDescriptorType type, const void* bytes, size_t size,
                                 const DescriptorTarget& target) {
  if (size == 0) return;
  std::string k = key(type, bytes, size);
  auto [it, added] = named_.insert_or_assign(k, target);
  if (!added) return;
  order_.push_back(std::move(k));
  ++sizes_[type][size];
  if (named_.size() <= kMaxDescriptors) return;
  const std::string& oldest = order_.front();
  auto& sizes = sizes_[typeOf(oldest)];
  if (auto s = sizes.find(oldest.size() - sizeof(int32_t)); s != sizes.end() && --s->second == 0) sizes.erase(s);
  named_.erase(oldest);
  order_.pop_front();
  forgot_ = true;
}

std::optional<DescriptorTarget> DescriptorCatalog::lookup(VkDescriptorType type, const uint8_t* bytes,
                                                          size_t available) const {
  auto sizes = sizes_.find(type);
  if (bytes == nullptr || sizes == sizes_.end()) return std::nullopt;
  for (const auto& [size, count] : sizes->second) {
    if (size > available) continue;
    auto it = named_.find(key(type, bytes, size));
    if (it != named_.end()) return it->second;
  }
  return std::nullopt;
}

void AddressPlaces::add(VkDeviceAddress address, const BufferPlace& place) {
  remove(place.buffer);
  starts_[address] = place;
  byBuffer_[place.buffer] = address;
}

void AddressPlaces::remove(uint64_t buffer) {
  auto it = byBuffer_.find(buffer);
  if (it == byBuffer_.end()) return;
  if (auto start = starts_.find(it->second); start != starts_.end() && start->second.buffer == buffer) {
    starts_.erase(start);
  }
  byBuffer_.erase(it);
}

std::optional<std::pair<VkDeviceAddress, BufferPlace>> AddressPlaces::find(VkDeviceAddress address) const {
  auto it = starts_.upper_bound(address);
  // A larger buffer that starts earlier may hold the address past a smaller
  // one's end: look back a few starts, not the whole table.
  constexpr int kLookBack = 64;
  for (int step = 0; step < kLookBack && it != starts_.begin(); ++step) {
    --it;
    if (address - it->first < it->second.size) return *it;
  }
  return std::nullopt;
}

void AddressPlaces::mapped(VkDeviceMemory memory, VkDeviceSize offset, VkDeviceSize size, void* host) {
  maps_[memory] = {offset, size, static_cast<uint8_t*>(host)};
}

void AddressPlaces::freed(VkDeviceMemory memory) {
  maps_.erase(memory);
  for (auto it = starts_.begin(); it != starts_.end();) {
    if (it->second.memory != memory) {
      ++it;
      continue;
    }
    byBuffer_.erase(it->second.buffer);
    it = starts_.erase(it);
  }
}

const uint8_t* AddressPlaces::host(VkDeviceAddress address, size_t& available) const {
  available = 0;
  auto found = find(address);
  if (!found) return nullptr;
  const auto& [start, place] = *found;
  auto map = maps_.find(place.memory);
  if (map == maps_.end() || map->second.host == nullptr) return nullptr;
  const VkDeviceSize at = place.memoryOffset + (address - start);
  const Mapping& m = map->second;
  if (at < m.offset || at - m.offset >= m.size) return nullptr;
  const VkDeviceSize bufferLeft = place.size - (address - start);
  available = size_t(std::min(bufferLeft, m.size - (at - m.offset)));
  return m.host + (at - m.offset);
}

VkDeviceSize descriptorSize(const VkPhysicalDeviceDescriptorBufferPropertiesEXT& p, bool robust,
                            const std::map<VkDescriptorType, size_t>& seen, VkDescriptorType type) {
  if (auto it = seen.find(type); it != seen.end()) return it->second;
  switch (type) {
    case VK_DESCRIPTOR_TYPE_SAMPLER: return p.samplerDescriptorSize;
    case VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER: return p.combinedImageSamplerDescriptorSize;
    case VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE: return p.sampledImageDescriptorSize;
    case VK_DESCRIPTOR_TYPE_STORAGE_IMAGE: return p.storageImageDescriptorSize;
    case VK_DESCRIPTOR_TYPE_INPUT_ATTACHMENT: return p.inputAttachmentDescriptorSize;
    case VK_DESCRIPTOR_TYPE_UNIFORM_TEXEL_BUFFER:
      return robust ? p.robustUniformTexelBufferDescriptorSize : p.uniformTexelBufferDescriptorSize;
    case VK_DESCRIPTOR_TYPE_STORAGE_TEXEL_BUFFER:
      return robust ? p.robustStorageTexelBufferDescriptorSize : p.storageTexelBufferDescriptorSize;
    case VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER:
      return robust ? p.robustUniformBufferDescriptorSize : p.uniformBufferDescriptorSize;
    case VK_DESCRIPTOR_TYPE_STORAGE_BUFFER:
      return robust ? p.robustStorageBufferDescriptorSize : p.storageBufferDescriptorSize;
    case VK_DESCRIPTOR_TYPE_ACCELERATION_STRUCTURE_KHR: return p.accelerationStructureDescriptorSize;
    default: return 0;
  }
}

std::optional<VkDeviceAddress> descriptorAddress(const std::vector<VkDeviceAddress>& buffers, uint32_t bufferIndex,
                                                 VkDeviceSize setOffset, const DescriptorBinding& binding,
                                                 uint32_t element, VkDeviceSize size) {
  if (bufferIndex >= buffers.size() || buffers[bufferIndex] == 0 || size == 0) return std::nullopt;
  if (binding.count != 0 && element >= binding.count) return std::nullopt;
  return buffers[bufferIndex] + setOffset + binding.offset + VkDeviceSize(element) * size;
}

bool roomForCounterBuffer(const VkPhysicalDeviceDescriptorBufferPropertiesEXT& props, uint32_t appBuffers,
                          uint32_t appResource) {
  return appBuffers + 1 <= props.maxDescriptorBufferBindings &&
         appResource + 1 <= props.maxResourceDescriptorBufferBindings;
}

}  // namespace tally::layer
