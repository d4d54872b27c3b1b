// A plain Vulkan application for the layer's robustness tests
// (tests/layer/robust_test.py). It never presents: under the layer a frame is
// a number of submissions (TALLY_LAYER_FRAME_SUBMITS). Every frame runs the
// fill kernel (app_support.hpp), whose counts the test derives from the
// dispatch size alone, and the application checks its own results.
//
//   --mode threads: two threads, each with its own command pool, buffer
//       ("out 0", "out 1") and label ("thread 0", "thread 1"), record and
//       submit fills of 1280 and 2240 invocations at the same time, on two
//       queues of one family where the device has two (else on its one
//       queue, each submission under the application's lock, as Vulkan
//       asks). Both wait for their work, then both go on to the next frame:
//       a frame is two submissions. Thread 0 records with ONE_TIME_SUBMIT,
//       thread 1 without.
//   --mode devices: two VkDevices of one instance, used in turn: frame f runs
//       a fill of 640 (device 0) or 1920 (device 1) invocations on device f % 2.
//   --mode reuse: one command buffer recorded once, before the first frame
//       (a fill of 2560), submitted once a frame.
//   --mode prerecorded: a command buffer per frame, all recorded with
//       ONE_TIME_SUBMIT before the first frame (a fill of 2560 each).
//   --mode many: one command buffer a frame, re-recorded each frame, with
//       600 fills in one labelled scope ("many"), fill i writing buffer
//       "out i" with 64 x (i % 5 + 1) invocations: 600 counter regions in one
//       recording, more than the layer's first arena chunk holds.
//   --mode oneshot: a command buffer allocated, recorded, submitted, waited
//       for and freed every frame (a fill of 2560), as one-shot helpers do.
//   --mode steady: three frames in flight, a fill of 256 a frame into the
//       frame's slot, which the application waits for three frames later,
//       never the frame before. Each frame also creates and destroys a small
//       buffer, as applications with per-frame uploads do. Prints the
//       process's VmRSS and heap in use at frame 1000 and after the last
//       frame, and the library its vkQueueSubmit comes from.
#include <dlfcn.h>
#include <malloc.h>

#include <barrier>
#include <fstream>
#include <mutex>
#include <thread>

#include "app_support.hpp"

namespace {

uint32_t frames = 10;

// The resident set of this process in KiB, from /proc/self/status.
long residentKiB() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) return std::strtol(line.c_str() + 6, nullptr, 10);
  }
  return -1;
}

// The process's heap in use in bytes (the layer's tables included: it
// allocates from the same heap), which unlike the resident set does not hide
// growth in memory the heap had already taken and freed.
size_t heapBytes() {
  const struct mallinfo2 info = mallinfo2();
  return info.uordblks + info.hblkhd;
}

void memoryAt(uint32_t frame) {
  std::printf("robust_app: memory at frame %u: rss %ld KiB, heap %zu B\n", frame, residentKiB(), heapBytes());
}

void begin(VkCommandBuffer cmd, VkCommandBufferUsageFlags flags) {
  VkCommandBufferBeginInfo info = {VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  info.flags = flags;
  app::check(vkBeginCommandBuffer(cmd, &info), "vkBeginCommandBuffer");
}

int threads(const app::Instance& instance) {
  app::Device device = app::createDevice(instance, 2);
  const bool shared = device.queues.size() < 2;
  std::printf("robust_app: threads on %zu queue(s)\n", device.queues.size());
  app::Fill fill = app::createFill(device, 2);
  const uint32_t invocations[2] = {1280, 2240};
  std::mutex queueLock;
  std::barrier frameEnd(2);
  bool ok[2] = {true, true};
  auto worker = [&](int t) {
    app::Buffer out = app::createBuffer(device, invocations[t] * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                        "out " + std::to_string(t));
    VkDescriptorSet set;
    {
      std::lock_guard lock(queueLock);  // the descriptor pool is shared: allocation needs the lock
      set = app::fillSet(device, fill, out.buffer);
    }
    VkCommandPool pool = app::createPool(device);
    VkCommandBuffer cmd = app::allocate(device, pool);
    VkFence fence = app::createFence(device);
    VkQueue queue = device.queues[shared ? 0 : size_t(t)];
    for (uint32_t f = 0; f < frames; ++f) {
      std::memset(out.mapped, 0, invocations[t] * 4);
      begin(cmd, t == 0 ? VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT : 0);
      app::recordFill(device, cmd, fill, set, invocations[t], "thread " + std::to_string(t));
      app::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
      if (shared) {
        std::lock_guard lock(queueLock);
        app::submit(queue, cmd, fence);
      } else {
        app::submit(queue, cmd, fence);
      }
      app::wait(device, fence);
      ok[t] = ok[t] && app::filled(out.mapped, invocations[t], "threads");
      frameEnd.arrive_and_wait();
    }
    vkDestroyFence(device.device, fence, nullptr);
    vkDestroyCommandPool(device.device, pool, nullptr);
    app::destroyBuffer(device, out);
  };
  std::thread a(worker, 0), b(worker, 1);
  a.join();
  b.join();
  app::destroyFill(device, fill);
  vkDestroyDevice(device.device, nullptr);
  return ok[0] && ok[1] ? 0 : 1;
}

int devices(const app::Instance& instance) {
  struct Side {
    app::Device device;
    app::Fill fill;
    app::Buffer out;
    VkDescriptorSet set;
    VkCommandPool pool;
    VkCommandBuffer cmd;
    VkFence fence;
    uint32_t invocations;
  };
  Side sides[2];
  for (uint32_t d = 0; d < 2; ++d) {
    Side& s = sides[d];
    s.device = app::createDevice(instance, 1);
    s.invocations = d == 0 ? 640 : 1920;
    s.fill = app::createFill(s.device, 1);
    s.out = app::createBuffer(s.device, s.invocations * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "out");
    s.set = app::fillSet(s.device, s.fill, s.out.buffer);
    s.pool = app::createPool(s.device);
    s.cmd = app::allocate(s.device, s.pool);
    s.fence = app::createFence(s.device);
  }
  bool ok = true;
  for (uint32_t f = 0; f < frames; ++f) {
    Side& s = sides[f % 2];
    std::memset(s.out.mapped, 0, s.invocations * 4);
    begin(s.cmd, 0);
    app::recordFill(s.device, s.cmd, s.fill, s.set, s.invocations, "fill");
    app::check(vkEndCommandBuffer(s.cmd), "vkEndCommandBuffer");
    app::submit(s.device.queues[0], s.cmd, s.fence);
    app::wait(s.device, s.fence);
    ok = ok && app::filled(s.out.mapped, s.invocations, "devices");
  }
  for (Side& s : sides) {
    vkDestroyFence(s.device.device, s.fence, nullptr);
    vkDestroyCommandPool(s.device.device, s.pool, nullptr);
    app::destroyBuffer(s.device, s.out);
    app::destroyFill(s.device, s.fill);
    vkDestroyDevice(s.device.device, nullptr);
  }
  return ok ? 0 : 1;
}

// reuse: one recording submitted every frame; prerecorded: one recording per
// frame, all made before the first submission.
int recordedAhead(const app::Instance& instance, bool once) {
  app::Device device = app::createDevice(instance, 1);
  constexpr uint32_t kInvocations = 2560;
  app::Fill fill = app::createFill(device, 1);
  app::Buffer out = app::createBuffer(device, kInvocations * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "out");
  VkDescriptorSet set = app::fillSet(device, fill, out.buffer);
  VkCommandPool pool = app::createPool(device);
  std::vector<VkCommandBuffer> cmds(once ? 1 : frames);
  for (auto& cmd : cmds) {
    cmd = app::allocate(device, pool);
    begin(cmd, once ? 0 : VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT);
    app::recordFill(device, cmd, fill, set, kInvocations, "fill");
    app::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
  }
  VkFence fence = app::createFence(device);
  bool ok = true;
  for (uint32_t f = 0; f < frames; ++f) {
    std::memset(out.mapped, 0, kInvocations * 4);
    app::submit(device.queues[0], cmds[once ? 0 : f], fence);
    app::wait(device, fence);
    ok = ok && app::filled(out.mapped, kInvocations, once ? "reuse" : "prerecorded");
  }
  vkDestroyFence(device.device, fence, nullptr);
  vkDestroyCommandPool(device.device, pool, nullptr);
  app::destroyBuffer(device, out);
  app::destroyFill(device, fill);
  vkDestroyDevice(device.device, nullptr);
  return ok ? 0 : 1;
}

int oneshot(const app::Instance& instance) {
  app::Device device = app::createDevice(instance, 1);
  constexpr uint32_t kInvocations = 2560;
  app::Fill fill = app::createFill(device, 1);
  app::Buffer out = app::createBuffer(device, kInvocations * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "out");
  VkDescriptorSet set = app::fillSet(device, fill, out.buffer);
  VkCommandPool pool = app::createPool(device);
  VkFence fence = app::createFence(device);
  bool ok = true;
  for (uint32_t f = 0; f < frames; ++f) {
    std::memset(out.mapped, 0, kInvocations * 4);
    VkCommandBuffer cmd = app::allocate(device, pool);
    begin(cmd, VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT);
    app::recordFill(device, cmd, fill, set, kInvocations, "fill");
    app::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    app::submit(device.queues[0], cmd, fence);
    app::wait(device, fence);
    vkFreeCommandBuffers(device.device, pool, 1, &cmd);
    ok = ok && app::filled(out.mapped, kInvocations, "oneshot");
  }
  vkDestroyFence(device.device, fence, nullptr);
  vkDestroyCommandPool(device.device, pool, nullptr);
  app::destroyBuffer(device, out);
  app::destroyFill(device, fill);
  vkDestroyDevice(device.device, nullptr);
  return ok ? 0 : 1;
}

int many(const app::Instance& instance) {
  constexpr uint32_t kFills = 600;
  app::Device device = app::createDevice(instance, 1);
  app::Fill fill = app::createFill(device, kFills);
  std::vector<app::Buffer> outs;
  std::vector<VkDescriptorSet> sets;
  auto invocations = [](uint32_t i) { return 64 * (i % 5 + 1); };
  for (uint32_t i = 0; i < kFills; ++i) {
    outs.push_back(app::createBuffer(device, invocations(i) * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                     "out " + std::to_string(i)));
    sets.push_back(app::fillSet(device, fill, outs.back().buffer));
  }
  VkCommandPool pool = app::createPool(device);
  VkCommandBuffer cmd = app::allocate(device, pool);
  VkFence fence = app::createFence(device);
  bool ok = true;
  for (uint32_t f = 0; f < frames; ++f) {
    for (uint32_t i = 0; i < kFills; ++i) std::memset(outs[i].mapped, 0, invocations(i) * 4);
    app::check(vkResetCommandPool(device.device, pool, 0), "vkResetCommandPool");
    begin(cmd, VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT);
    app::label(device, cmd, "many");
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, fill.pipeline);
    for (uint32_t i = 0; i < kFills; ++i) {
      vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, fill.layout, 0, 1, &sets[i], 0, nullptr);
      vkCmdDispatch(cmd, invocations(i) / 64, 1, 1);
    }
    app::unlabel(device, cmd);
    VkMemoryBarrier host = {VK_STRUCTURE_TYPE_MEMORY_BARRIER, nullptr, VK_ACCESS_SHADER_WRITE_BIT,
                            VK_ACCESS_HOST_READ_BIT};
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1, &host, 0,
                         nullptr, 0, nullptr);
    app::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    app::submit(device.queues[0], cmd, fence);
    app::wait(device, fence);
    for (uint32_t i = 0; i < kFills; ++i) ok = ok && app::filled(outs[i].mapped, invocations(i), "many");
  }
  vkDestroyFence(device.device, fence, nullptr);
  vkDestroyCommandPool(device.device, pool, nullptr);
  for (auto& out : outs) app::destroyBuffer(device, out);
  app::destroyFill(device, fill);
  vkDestroyDevice(device.device, nullptr);
  return ok ? 0 : 1;
}

// Which library answers the application's vkQueueSubmit: the layer's when it
// intercepts the call, the driver's when the layer stays out of the way.
void printSubmitLibrary(const app::Device& device) {
  Dl_info info{};
  auto submit = vkGetDeviceProcAddr(device.device, "vkQueueSubmit");
  const char* file = submit != nullptr && dladdr(reinterpret_cast<void*>(submit), &info) != 0 ? info.dli_fname : "?";
  std::printf("robust_app: vkQueueSubmit is in %s\n", file);
}

int steady(const app::Instance& instance) {
  app::Device device = app::createDevice(instance, 1);
  printSubmitLibrary(device);
  constexpr uint32_t kInFlight = 3, kInvocations = 256;
  app::Fill fill = app::createFill(device, kInFlight);
  VkCommandPool pool = app::createPool(device);
  struct Slot {
    app::Buffer out;
    VkDescriptorSet set;
    VkCommandBuffer cmd;
    VkFence fence;
    VkBuffer transient = VK_NULL_HANDLE;
    bool used = false;
  };
  Slot slots[kInFlight];
  for (Slot& s : slots) {
    s.out = app::createBuffer(device, kInvocations * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "out");
    s.set = app::fillSet(device, fill, s.out.buffer);
    s.cmd = app::allocate(device, pool);
    s.fence = app::createFence(device);
  }
  bool ok = true;
  for (uint32_t f = 0; f < frames; ++f) {
    Slot& s = slots[f % kInFlight];
    if (s.used) {  // this slot's frame, three frames ago
      app::wait(device, s.fence);
      ok = ok && app::filled(s.out.mapped, kInvocations, "steady");
      vkDestroyBuffer(device.device, s.transient, nullptr);
    }
    VkBufferCreateInfo bci = {VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
    bci.size = 256;
    bci.usage = VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
    app::check(vkCreateBuffer(device.device, &bci, nullptr, &s.transient), "vkCreateBuffer");
    std::memset(s.out.mapped, 0, kInvocations * 4);
    begin(s.cmd, 0);
    app::recordFill(device, s.cmd, fill, s.set, kInvocations, "fill");
    app::check(vkEndCommandBuffer(s.cmd), "vkEndCommandBuffer");
    app::submit(device.queues[0], s.cmd, s.fence);
    s.used = true;
    if (f + 1 == 1000) memoryAt(1000);
  }
  memoryAt(frames);
  for (Slot& s : slots) {
    if (s.used) {
      app::wait(device, s.fence);
      ok = ok && app::filled(s.out.mapped, kInvocations, "steady");
      vkDestroyBuffer(device.device, s.transient, nullptr);
    }
    vkDestroyFence(device.device, s.fence, nullptr);
    app::destroyBuffer(device, s.out);
  }
  vkDestroyCommandPool(device.device, pool, nullptr);
  app::destroyFill(device, fill);
  vkDestroyDevice(device.device, nullptr);
  return ok ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  std::string mode;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    if (flag == "--mode") mode = argv[i + 1];
    else if (flag == "--frames") frames = uint32_t(std::strtoul(argv[i + 1], nullptr, 10));
  }
  if (mode != "threads" && mode != "devices" && mode != "reuse" && mode != "prerecorded" && mode != "steady" &&
      mode != "many" && mode != "oneshot") {
    std::fprintf(stderr, "robust_app: --mode threads|devices|reuse|prerecorded|steady|many|oneshot [--frames N]\n");
    return 2;
  }
  app::Instance instance = app::createInstance("robust_app", {});
  int status = mode == "threads"       ? threads(instance)
               : mode == "devices"     ? devices(instance)
               : mode == "reuse"       ? recordedAhead(instance, true)
               : mode == "prerecorded" ? recordedAhead(instance, false)
               : mode == "many"        ? many(instance)
               : mode == "oneshot"     ? oneshot(instance)
                                       : steady(instance);
  vkDestroyInstance(instance.instance, nullptr);
  if (status == 0) std::printf("robust_app: %s, %u frames, results correct\n", mode.c_str(), frames);
  return status;
}
