// Objects the application destroys: what the layer keeps of them, and for how
// long. A resource may still be named by a readback in flight, so it is
// forgotten only once every readback submitted before its destruction has
// been read, and never if a frame of the window counted it (the output lists
// it). Applications that create and destroy objects every frame then leave
// the layer's tables the size they had.
#include <algorithm>

#include "state.hpp"

namespace tally::layer {

void retireResource(DeviceState& dev, uint64_t handle) {
  auto it = dev.resources.find(handle);
  if (it == dev.resources.end()) return;
  it->second.destroyed = true;
  dev.retired[handle] = dev.nextHarvest;
}

void forgetRetired(DeviceState& dev) {
  if (dev.retired.empty()) return;
  uint64_t oldest = dev.nextHarvest;  // the oldest readback still pending
  for (const auto& h : dev.pending) oldest = std::min(oldest, h->serial);
  for (auto it = dev.retired.begin(); it != dev.retired.end();) {
    if (it->second > oldest) {
      ++it;
      continue;
    }
    // A handle the driver gave to a new resource since is that resource's.
    auto r = dev.resources.find(it->first);
    if (r != dev.resources.end() && r->second.destroyed && !r->second.counted) dev.resources.erase(r);
    it = dev.retired.erase(it);
  }
}

}  // namespace tally::layer
