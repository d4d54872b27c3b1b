// The instrumented search of a physical-storage-buffer access's address
// (server/spirv/address_sites.cpp), run on the device with a hand-built
// table, without the layer: address_app's kernel, instrumented with an
// address table, counts into a counter buffer this program binds and reads.
// The table lists "bda read" (slot 2) and "bda read-write" (slot 3) only,
// so the writes to "bda written" (256) and "bda scratch" (64) land in the
// unknown-address slot: the one line no legitimate application call yields
// on lavapipe (tests/layer/address_test.py). Expected counts by hand from
// the kernel: reads 320 of "bda read" (256 + 64 through the middle
// pointer), 320 of "bda read-write"; writes 320 of "bda read-write",
// 256 + 64 unknown. The same kernel instrumented without a table counts
// one slot per kind and width: the lines by address sum to it.
#include <map>

#include "address_app.hpp"
#include "spirv/address_table.hpp"
#include "spirv/instrument.hpp"

namespace {

using namespace address;
namespace spirv = tally::spirv;

VkDescriptorSetLayout setLayout(const app::Device& device) {
  VkDescriptorSetLayoutBinding bindings[2] = {
      {0, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}};
  VkDescriptorSetLayoutCreateInfo info = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  info.bindingCount = 2;
  info.pBindings = bindings;
  VkDescriptorSetLayout out;
  app::check(vkCreateDescriptorSetLayout(device.device, &info, nullptr, &out), "vkCreateDescriptorSetLayout");
  return out;
}

VkDescriptorSet writeSet(const app::Device& device, VkDescriptorPool pool, VkDescriptorSetLayout layout,
                         VkBuffer counters, VkBuffer table) {
  VkDescriptorSetAllocateInfo info = {VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
  info.descriptorPool = pool;
  info.descriptorSetCount = 1;
  info.pSetLayouts = &layout;
  VkDescriptorSet set;
  app::check(vkAllocateDescriptorSets(device.device, &info, &set), "vkAllocateDescriptorSets");
  VkDescriptorBufferInfo buffers[2] = {{counters, 0, VK_WHOLE_SIZE}, {table, 0, VK_WHOLE_SIZE}};
  VkWriteDescriptorSet writes[2] = {};
  for (uint32_t i = 0; i < 2; ++i) {
    writes[i] = {VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
    writes[i].dstSet = set;
    writes[i].dstBinding = i;
    writes[i].descriptorCount = 1;
    writes[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    writes[i].pBufferInfo = &buffers[i];
  }
  vkUpdateDescriptorSets(device.device, 2, writes, 0, nullptr);
  return set;
}

// Counts per (write, slot from the site's first) of the kernel instrumented
// with `table` (none: without an address table), summed over the slot
// ranges of the kind; zero counts left out.
using Counts = std::map<std::pair<bool, uint32_t>, uint64_t>;

Counts countSlots(const app::Device& device, const Pointers& p, const spirv::AddressTable* table) {
  spirv::InstrumentOptions options;
  options.set = 0;
  options.binding = 0;
  options.addressTable = table != nullptr;
  options.addressTableBinding = 1;
  options.width = spirv::CounterWidth::Uint32Pair;  // no 64-bit atomics needed
  auto instrumented = spirv::instrument(kernelWords(), options);
  if (!instrumented) {
    std::fprintf(stderr, "address_search: %s\n", instrumented.error().c_str());
    std::exit(1);
  }
  const std::vector<uint64_t> words = table != nullptr ? table->words : std::vector<uint64_t>{0};
  app::Buffer counters =
      app::createBuffer(device, instrumented->slotCount * 8, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "");
  app::Buffer tableBuffer =
      app::createBuffer(device, words.size() * 8, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "");
  std::memset(counters.mapped, 0, instrumented->slotCount * 8);
  std::memcpy(tableBuffer.mapped, words.data(), words.size() * 8);
  VkDescriptorSetLayout layout = setLayout(device);
  VkDescriptorPoolSize size = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2};
  VkDescriptorPoolCreateInfo poolInfo = {VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  poolInfo.maxSets = 1;
  poolInfo.poolSizeCount = 1;
  poolInfo.pPoolSizes = &size;
  VkDescriptorPool descriptorPool;
  app::check(vkCreateDescriptorPool(device.device, &poolInfo, nullptr, &descriptorPool),
             "vkCreateDescriptorPool");
  VkDescriptorSet set = writeSet(device, descriptorPool, layout, counters.buffer, tableBuffer.buffer);
  Kernel kernel = createKernel(device, instrumented->words, layout);
  VkCommandPool pool = app::createPool(device);
  VkCommandBuffer cmd = app::allocate(device, pool);
  VkFence fence = app::createFence(device);
  VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  app::check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, kernel.pipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, kernel.layout, 0, 1, &set, 0, nullptr);
  vkCmdPushConstants(cmd, kernel.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(p), &p);
  vkCmdDispatch(cmd, kWords / 64, 1, 1);
  app::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
  app::submit(device.queues[0], cmd, fence);
  app::wait(device, fence);
  Counts got;
  std::map<uint32_t, bool> ranged;
  for (const auto& site : instrumented->sites) {
    const bool write = site.kind == spirv::SiteKind::BufferWrite;
    if ((!write && site.kind != spirv::SiteKind::BufferRead) || ranged.count(site.slot)) continue;
    ranged[site.slot] = true;
    for (uint32_t i = 0; i < site.slotCount; ++i) {
      const uint32_t s = site.slot + i;
      const uint64_t n = uint64_t(counters.mapped[2 * s]) | uint64_t(counters.mapped[2 * s + 1]) << 32;
      if (n != 0) got[{write, i}] += n;
    }
  }
  app::destroyBuffer(device, counters);
  app::destroyBuffer(device, tableBuffer);
  vkDestroyFence(device.device, fence, nullptr);
  vkDestroyCommandPool(device.device, pool, nullptr);
  vkDestroyPipeline(device.device, kernel.pipeline, nullptr);
  vkDestroyPipelineLayout(device.device, kernel.layout, nullptr);
  vkDestroyDescriptorPool(device.device, descriptorPool, nullptr);
  vkDestroyDescriptorSetLayout(device.device, layout, nullptr);
  return got;
}

bool same(const Counts& got, const Counts& expected, const char* what) {
  if (got == expected) return true;
  for (const auto& [key, n] : got) {
    std::fprintf(stderr, "address_search: %s: %s slot %u counted %llu\n", what, key.first ? "write" : "read",
                 key.second, static_cast<unsigned long long>(n));
  }
  std::fprintf(stderr, "address_search: %s: not the %zu slots expected\n", what, expected.size());
  return false;
}

}  // namespace

int main() {
  app::Instance instance = createInstance();
  app::Device device = createDevice(instance, true);
  Pointers p{};
  app::Buffer src = addressed(device, "bda read", false, p.src);
  app::Buffer dst = addressed(device, "bda written", false, p.dst);
  app::Buffer both = addressed(device, "bda read-write", true, p.both);
  app::Buffer scratch = addressed(device, "bda scratch", true, p.scratch);
  p.middle = p.src + 128 * 4;
  const uint32_t kRead = spirv::kAddressFirstBufferSlot, kBoth = spirv::kAddressFirstBufferSlot + 1;
  const std::vector<spirv::AddressRange> ranges = {{p.src, p.src + kWords * 4, kRead},
                                                   {p.both, p.both + kWords * 4, kBoth}};
  const spirv::AddressTable table = spirv::buildAddressTable(ranges);
  const Counts byAddress = countSlots(device, p, &table), byWidth = countSlots(device, p, nullptr);
  const bool ok = same(byAddress,
                       {{{false, kRead}, 320},
                        {{false, kBoth}, 320},
                        {{true, kBoth}, 320},
                        {{true, spirv::kAddressUnknownSlot}, 320}},
                       "by address") &&
                  same(byWidth, {{{false, 0}, 640}, {{true, 0}, 640}}, "by width");
  for (auto* b : {&src, &dst, &both, &scratch}) app::destroyBuffer(device, *b);
  vkDestroyDevice(device.device, nullptr);
  vkDestroyInstance(instance.instance, nullptr);
  if (!ok) return 1;
  std::printf(
      "address_search: reads and writes in the slots the hand-built table gives, the rest unknown; "
      "they sum to the counts by width\n");
  return 0;
}
