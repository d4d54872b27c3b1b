// The counted window: which command buffers the layer records for counting,
// which frames it reads, and where each device's output goes (docs/layer.md,
// "What the layer changes in the application"). Outside the window the
// application binds its own pipelines and the layer adds nothing to its
// command buffers or queues: no counter set, no queries, no readback.
#include <atomic>
#include <filesystem>

#include "state.hpp"

namespace tally::layer {

bool windowAhead(const DeviceState& dev) { return dev.counting && !dev.config.output.empty() && !dev.written; }

namespace {

// One past the window's last frame: each frame left out extends it by one,
// so that the output still holds the frames asked for.
uint64_t windowEnd(const DeviceState& dev) {
  return uint64_t(dev.config.skipFrames) + dev.config.frames + dev.framesLeftOut;
}

}  // namespace

bool inWindow(const DeviceState& dev, uint64_t frame) {
  return windowAhead(dev) && frame >= dev.config.skipFrames && frame < windowEnd(dev);
}

bool recordForCounting(DeviceState& dev, CommandBufferState& cb, VkCommandBufferUsageFlags flags) {
  if (cb.submitsOfRecording > 1) cb.resubmitted = true;
  cb.submitsOfRecording = 0;
  ++cb.recordings;
  if (!windowAhead(dev) || dev.frame >= windowEnd(dev)) return false;
  // Inside the window, and one frame before it: applications (zink among
  // them) begin a frame's command buffer before the previous frame's present.
  if (dev.frame + 1 >= dev.config.skipFrames) return true;
  // Earlier, only a command buffer that may still run inside the window: a
  // first recording the application may submit again and again (vkcube
  // records its command buffers once), or one whose recordings were submitted
  // more than once. A command buffer recorded anew for each submission runs
  // uninstrumented until the window.
  if (flags & VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT) return false;
  return cb.recordings == 1 || cb.resubmitted;
}

void assignOutput(DeviceState& dev) {
  static std::atomic<uint32_t> next{0};
  dev.index = next++;
  if (dev.index == 0 || dev.config.output.empty()) return;
  // The second device of a process writes x.device1.json beside x.json, so
  // the first device's output stays where a reader waits for it.
  std::filesystem::path path(dev.config.output);
  const std::string extension = path.extension().string();
  path.replace_extension();
  dev.config.output = path.string() + ".device" + std::to_string(dev.index) + extension;
}

uint32_t framesCounted(const DeviceState& dev) { return dev.framesDone; }

}  // namespace tally::layer
