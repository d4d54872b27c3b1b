// A plain Vulkan application that reaches its buffers only by device address
// (tests/layer/address_test.py). It never presents: each frame is one
// submission of one compute pass, "by address", of 256 invocations whose
// shader reads and writes through buffer_reference pointers from push
// constants, 4-byte words:
//   "bda read":       pc.src[i] for every i, and pc.middle[i] for i < 64,
//                     where middle points 128 words into "bda read";
//   "bda written":    pc.dst[i] = ... for every i;
//   "bda read-write": pc.both[i] += ... for every i, and again for i < 64;
//   "bda scratch":    pc.scratch[i] = i for i < 64, a buffer created, bound
//                     (vkBindBufferMemory2), addressed and destroyed every
//                     frame, so that the layer's address table changes
//                     between submissions.
// It checks its own results, so a layer that changed what it computes fails.
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "address_app.hpp"

namespace {

using namespace address;

bool expect(uint32_t got, uint32_t want, const char* what, uint32_t i) {
  if (got == want) return true;
  std::fprintf(stderr, "address_app: %s[%u] = %u, expected %u\n", what, i, got, want);
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  uint32_t frames = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    if (std::strcmp(argv[i], "--frames") == 0) frames = uint32_t(std::atoi(argv[i + 1]));
  }
  app::Instance instance = createInstance();
  app::Device device = createDevice(instance);
  Pointers p{};
  app::Buffer src = addressed(device, "bda read", false, p.src);
  app::Buffer dst = addressed(device, "bda written", false, p.dst);
  app::Buffer both = addressed(device, "bda read-write", true, p.both);
  p.middle = p.src + 128 * 4;
  for (uint32_t i = 0; i < kWords; ++i) src.mapped[i] = i + 1;
  Kernel kernel = createKernel(device, kernelWords(), VK_NULL_HANDLE);
  VkCommandPool pool = app::createPool(device);
  VkCommandBuffer cmd = app::allocate(device, pool);
  VkFence fence = app::createFence(device);
  bool ok = true;
  for (uint32_t frame = 0; frame < frames; ++frame) {
    app::Buffer scratch = addressed(device, "bda scratch", true, p.scratch);
    VkCommandBufferBeginInfo begin = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    app::check(vkBeginCommandBuffer(cmd, &begin), "vkBeginCommandBuffer");
    app::label(device, cmd, "by address");
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, kernel.pipeline);
    vkCmdPushConstants(cmd, kernel.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(p), &p);
    vkCmdDispatch(cmd, kWords / 64, 1, 1);
    app::unlabel(device, cmd);
    app::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    app::submit(device.queues[0], cmd, fence);
    app::wait(device, fence);
    for (uint32_t i = 0; i < kWords && ok; ++i) {
      const uint32_t v = i + 1, middle = i < 64 ? i + 129 : 0;
      ok = expect(dst.mapped[i], 2 * v, "written", i) &&
           expect(both.mapped[i], (frame + 1) * (v + middle), "read-write", i) &&
           expect(scratch.mapped[i], i < 64 ? i : 0, "scratch", i);
    }
    app::destroyBuffer(device, scratch);
  }
  vkDestroyFence(device.device, fence, nullptr);
  vkDestroyCommandPool(device.device, pool, nullptr);
  vkDestroyPipeline(device.device, kernel.pipeline, nullptr);
  vkDestroyPipelineLayout(device.device, kernel.layout, nullptr);
  app::destroyBuffer(device, src);
  app::destroyBuffer(device, dst);
  app::destroyBuffer(device, both);
  vkDestroyDevice(device.device, nullptr);
  vkDestroyInstance(instance.instance, nullptr);
  if (!ok) return 1;
  std::printf("address_app: %u frames, results as expected\n", frames);
  return 0;
}
