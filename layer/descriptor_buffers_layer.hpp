// VK_EXT_descriptor_buffer counted (descriptor_buffers_layer.cpp): the
// layer's counter set in a descriptor buffer of its own, appended to the
// application's bound ones, and each line named by the resource whose
// descriptor the application wrote where the shader reads. The hooks below
// are what the rest of the layer calls; docs/layer.md, "Descriptor buffers".
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include "state.hpp"

namespace tally::layer {

PFN_vkVoidFunction interceptedDescriptorBuffers(std::string_view name);

// CreateDevice, before setupCounting: whether the application enabled
// descriptor buffers (and buffer device addresses, which they need).
void prepareDescriptorBuffers(DeviceState& dev, const VkDeviceCreateInfo& info);
// The usage the counter buffer needs beside its own (its device address).
VkBufferUsageFlags counterBufferAddressUsage(const DeviceState& dev);
// setupCounting, once the counter buffer exists: the descriptor-buffer
// counter set layout and the layer's descriptor buffer. Under dev.mutex.
void setupDescriptorBuffers(DeviceState& dev);
void destroyDescriptorBuffers(DeviceState& dev);

// A set layout was created (outside dev.mutex): its binding offsets, where it is for descriptor buffers.
void noteDescriptorSetLayout(DeviceState& dev, VkDescriptorSetLayout layout, const VkDescriptorSetLayoutCreateInfo& info);
void noteBufferUsage(DeviceState& dev, VkBuffer buffer, VkBufferUsageFlags usage);  // under dev.mutex
// Memory bound to a buffer (under dev.mutex): where a buffer whose address
// a descriptor may hold lies. vkBindBufferMemory[2] here call it; another
// area that intercepts them too must call it as well.
void noteBufferMemory(DeviceState& dev, VkBuffer buffer, VkDeviceMemory memory, VkDeviceSize offset);
// Pipeline layouts, under dev.mutex: whether `info` is a descriptor-buffer
// layout the layer counts (its counter and padding set layouts in `counter`
// and `empty`); a created layout's sets remembered.
bool descriptorBufferLayouts(const DeviceState& dev, const VkPipelineLayoutCreateInfo& info,
                             VkDescriptorSetLayout& counter, VkDescriptorSetLayout& empty);
// Whether `layout` is a descriptor-buffer pipeline layout the layer counts
// (under dev.mutex): its counter set has no buffer-address table.
bool isDescriptorBufferLayout(const DeviceState& dev, VkPipelineLayout layout);
bool countsDescriptorBuffers(const DeviceState& dev);
void notePipelineLayout(DeviceState& dev, VkPipelineLayout layout, const VkPipelineLayoutCreateInfo& info);

// At a draw, under dev.mutex: the device address of the descriptor a site's
// element reads where its set lives in a descriptor buffer, and its type (none otherwise).
std::optional<DescriptorPlace> descriptorBufferAddress(const DeviceState& dev, const CommandBufferState& cb,
                                                       uint32_t bindPoint, const PipelineInfo& pipeline,
                                                       const spirv::Site& site, uint32_t element);
// Binds the counter set at `offset` where the pipeline's layout is a
// descriptor-buffer one: false when it is not (the ordinary set is bound).
bool bindCounterDescriptor(DeviceState& dev, CommandBufferState& cb, uint32_t bindPoint, const PipelineInfo& pipeline,
                           VkDeviceSize offset);
// Whether a draw of this pipeline may count: false where its layout uses
// descriptor buffers and the layer's own could not be bound beside the
// application's (the application's own pipeline is then bound for it).
bool descriptorBuffersReady(DeviceState& dev, CommandBufferState& cb, uint32_t bindPoint);

// At a submission, under dev.mutex: each region's descriptor-buffer slots
// named from the bytes the application's buffers hold now.
void nameDescriptorBufferSlots(DeviceState& dev, std::vector<Region>& regions);

}  // namespace tally::layer
