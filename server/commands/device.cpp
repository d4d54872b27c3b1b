// tallyd device: the Vulkan device a capture would run on, as the "device"
// object every result records (gpu::describe). Workers of a fleet run it once
// at start, in a child process, to register what they can capture on and to
// claim only the jobs whose device requirement it meets (docs/fleet.md).
#include <cstdio>

#include "commands/commands.hpp"
#include "gpu/context.hpp"

namespace tally::cli {

int runDevice(const DeviceArgs& args) {
  auto described = gpu::withDevice(args.device, [](gpu::Context& ctx) -> Result<nlohmann::json> {
    return gpu::describe(ctx);
  });
  if (!described) {
    std::fprintf(stderr, "tallyd device: %s\n", described.error().c_str());
    return 1;
  }
  if (args.json) {
    std::printf("%s\n", described->dump().c_str());
  } else {
    const auto& d = *described;
    std::printf("%s (%s, vendor %s, driver %s, Vulkan %s)\n", d.value("name", "").c_str(), d.value("type", "").c_str(),
                d.value("vendorID", "").c_str(), d.value("driverInfo", "").c_str(), d.value("apiVersion", "").c_str());
  }
  return 0;
}

}  // namespace tally::cli
