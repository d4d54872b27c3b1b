// Runs a capture spec: one sample per (renderer, scene, resolution, camera).
// See docs/result-schema.md for the result it returns.
#pragma once

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "capture/spec.hpp"
#include "gpu/context.hpp"
#include "common/result.hpp"

namespace tally::capture {

struct CaptureProgress {
  size_t done = 0;   // samples finished
  size_t total = 0;  // samples in the matrix
  std::string current;  // "deferred atrium 320x180 camera 3"
};

struct CaptureOptions {
  std::string device;         // as gpu::ContextOptions::device
  std::string screenshotDir;  // PNGs are written here; "" keeps none
  std::function<void(const CaptureProgress&)> progress;
};

// Fails with a reason naming the sample on errors that end the capture (no
// device, a scene that does not load, a renderer the device cannot run).
Result<nlohmann::json> runCapture(const CaptureSpec& spec, const CaptureOptions& options);

// Opens the device (as gpu::ContextOptions::device), runs `work` on it and
// closes it again, whatever `work` returns. Fails first if there is no such device.
Result<nlohmann::json> withDevice(const std::string& device,
                                  const std::function<Result<nlohmann::json>(gpu::Context&)>& work);

}  // namespace tally::capture
