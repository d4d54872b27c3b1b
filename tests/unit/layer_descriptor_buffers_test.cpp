// The layer's descriptor-buffer bookkeeping (layer/descriptor_buffers.cpp),
// without a device: descriptor bytes to resources, addresses to the
// application's host mapping, and where a binding's element lies.
#include <gtest/gtest.h>

#include <array>
#include <vector>

#include "layer/descriptor_buffers.hpp"

namespace tally::layer {
namespace {

TEST(DescriptorCatalog, NamesTheResourceWhoseDescriptorWasWritten) {
  DescriptorCatalog catalog;
  const std::array<uint8_t, 16> texture = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16};
  const std::array<uint8_t, 8> buffer = {1, 2, 3, 4, 5, 6, 7, 9};
  catalog.remember(VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, texture.data(), texture.size(),
                   {0x100, VK_FORMAT_R8G8B8A8_UNORM, VK_IMAGE_ASPECT_COLOR_BIT});
  catalog.remember(VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, buffer.data(), buffer.size(), {0x200});
  // A copy of the bytes, as the application writes them into its buffer, with more descriptors after.
  std::vector<uint8_t> memory(texture.begin(), texture.end());
  memory.insert(memory.end(), buffer.begin(), buffer.end());
  memory.resize(64, 0xEE);
  auto first = catalog.lookup(VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, memory.data(), memory.size());
  ASSERT_TRUE(first);
  EXPECT_EQ(first->resource, 0x100u);
  EXPECT_EQ(first->format, VK_FORMAT_R8G8B8A8_UNORM);
  auto second = catalog.lookup(VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, memory.data() + 16, memory.size() - 16);
  ASSERT_TRUE(second);
  EXPECT_EQ(second->resource, 0x200u);
  // Past the written descriptors: no false match.
  EXPECT_FALSE(catalog.lookup(VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, memory.data() + 32, memory.size() - 32));
  // Fewer bytes readable than the descriptor.
  EXPECT_FALSE(catalog.lookup(VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, memory.data(), 12));
  // The same bytes read as another type name nothing: a storage image is not the sampled one.
  EXPECT_FALSE(catalog.lookup(VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, memory.data(), memory.size()));
}

TEST(DescriptorCatalog, SmallHandlesOfDifferentTypesStayApart) {
  DescriptorCatalog catalog;
  const uint32_t handle = 5;  // as a driver with 4-byte image descriptors may give for two types
  catalog.remember(VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, &handle, 4, {0xA});
  catalog.remember(VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, &handle, 4, {0xB});
  const auto* bytes = reinterpret_cast<const uint8_t*>(&handle);
  EXPECT_EQ(catalog.lookup(VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, bytes, 4)->resource, 0xAu);
  EXPECT_EQ(catalog.lookup(VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, bytes, 4)->resource, 0xBu);
}

TEST(DescriptorCatalog, RewrittenBytesNameTheLatestResource) {
  DescriptorCatalog catalog;
  const std::array<uint8_t, 4> bytes = {9, 9, 9, 9};
  catalog.remember(VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, bytes.data(), bytes.size(), {0x1});
  catalog.remember(VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, bytes.data(), bytes.size(), {0x2});
  EXPECT_EQ(catalog.size(), 1u);
  EXPECT_EQ(catalog.lookup(VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, bytes.data(), 4)->resource, 0x2u);
}

TEST(DescriptorCatalog, ForgetsTheOldestPastItsBound) {
  DescriptorCatalog catalog;
  constexpr auto kType = VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER;
  for (uint32_t i = 0; i <= DescriptorCatalog::kMaxDescriptors; ++i) catalog.remember(kType, &i, sizeof i, {i + 1});
  EXPECT_EQ(catalog.size(), DescriptorCatalog::kMaxDescriptors);
  EXPECT_TRUE(catalog.forgotSome());
  const uint32_t oldest = 0, newest = DescriptorCatalog::kMaxDescriptors;
  EXPECT_FALSE(catalog.lookup(kType, reinterpret_cast<const uint8_t*>(&oldest), 4));
  EXPECT_EQ(catalog.lookup(kType, reinterpret_cast<const uint8_t*>(&newest), 4)->resource, newest + 1);
}

TEST(AddressPlaces, ReadsThroughTheApplicationsMapping) {
  AddressPlaces places;
  std::vector<uint8_t> mapping(4096);
  for (size_t i = 0; i < mapping.size(); ++i) mapping[i] = uint8_t(i);
  auto memory = reinterpret_cast<VkDeviceMemory>(uintptr_t(0x77));
  // The buffer lies 1024 bytes into its memory; the application mapped from 512.
  places.add(0x10000, {0xB0, 2048, memory, 1024});
  size_t available = 0;
  EXPECT_EQ(places.host(0x10000, available), nullptr);  // not mapped yet
  places.mapped(memory, 512, 4096 - 512, mapping.data());
  const uint8_t* at = places.host(0x10000 + 100, available);
  ASSERT_NE(at, nullptr);
  EXPECT_EQ(at, mapping.data() + (1024 + 100 - 512));
  EXPECT_EQ(available, 2048u - 100u);
  EXPECT_EQ(places.host(0x10000 + 2048, available), nullptr);  // past the buffer
  EXPECT_EQ(places.find(0x10000 + 2047)->second.buffer, 0xB0u);
  places.unmapped(memory);
  EXPECT_EQ(places.host(0x10000, available), nullptr);
}

TEST(AddressPlaces, FindsTheBufferHoldingAnAddressAndForgetsDestroyedOnes) {
  AddressPlaces places;
  auto memory = reinterpret_cast<VkDeviceMemory>(uintptr_t(0x5));
  places.add(0x1000, {0xA, 0x10000, memory, 0});  // large
  places.add(0x2000, {0xB, 0x100, memory, 0x1000});  // inside the large one's range
  EXPECT_EQ(places.find(0x2010)->second.buffer, 0xBu);
  EXPECT_EQ(places.find(0x3000)->second.buffer, 0xAu);  // past B's end, still A's
  EXPECT_FALSE(places.find(0x800));
  places.remove(0xB);
  EXPECT_EQ(places.find(0x2010)->second.buffer, 0xAu);
  places.freed(memory);
  EXPECT_FALSE(places.find(0x2010));
}

TEST(DescriptorBufferOffsets, ElementAddressAndSizes) {
  VkPhysicalDeviceDescriptorBufferPropertiesEXT props = {};
  props.sampledImageDescriptorSize = 32;
  props.storageBufferDescriptorSize = 16;
  props.robustStorageBufferDescriptorSize = 24;
  props.maxDescriptorBufferBindings = 3;
  props.maxResourceDescriptorBufferBindings = 2;
  std::map<VkDescriptorType, size_t> seen;
  EXPECT_EQ(descriptorSize(props, false, seen, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER), 16u);
  EXPECT_EQ(descriptorSize(props, true, seen, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER), 24u);
  seen[VK_DESCRIPTOR_TYPE_STORAGE_BUFFER] = 24;  // what the application asked vkGetDescriptorEXT for
  EXPECT_EQ(descriptorSize(props, false, seen, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER), 24u);

  const std::vector<VkDeviceAddress> bound = {0x100000, 0x200000};
  const DescriptorBinding textures = {64, VK_DESCRIPTOR_TYPE_SAMPLED_IMAGE, 4};
  EXPECT_EQ(descriptorAddress(bound, 1, 0x400, textures, 3, 32), VkDeviceAddress(0x200000 + 0x400 + 64 + 3 * 32));
  EXPECT_FALSE(descriptorAddress(bound, 2, 0, textures, 0, 32));  // no buffer at that index
  EXPECT_FALSE(descriptorAddress(bound, 0, 0, textures, 4, 32));  // past the binding's count

  EXPECT_TRUE(roomForCounterBuffer(props, 1, 1));
  EXPECT_FALSE(roomForCounterBuffer(props, 2, 2));  // no resource binding left
  EXPECT_FALSE(roomForCounterBuffer(props, 3, 1));  // no binding left
}

}  // namespace
}  // namespace tally::layer
