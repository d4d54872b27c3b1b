// Runs a capture spec: one sample per (renderer, scene, resolution, camera).
// See docs/result-schema.md for the result it returns.
#pragma once

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "capture/spec.hpp"
#include "sweeps/sweep.hpp"
#include "gpu/context.hpp"
#include "common/progress.hpp"
#include "common/result.hpp"

namespace tally::capture {

using CaptureProgress = Progress;  // samples of the matrix, or a sweep's steps

struct CaptureOptions {
  std::string device;         // as gpu::ContextOptions::device
  std::string screenshotDir;  // PNGs are written here; "" keeps none
  std::function<void(const CaptureProgress&)> progress;
};

// Fails with a reason naming the sample on errors that end the capture (no
// device, a scene that does not load, a renderer the device cannot run).
Result<nlohmann::json> runCapture(const CaptureSpec& spec, const CaptureOptions& options);

// Runs a stability sweep (a spec with "sweep", sweeps/sweep.hpp) on the
// device the options name, as runCapture runs a matrix.
Result<nlohmann::json> runSweep(const sweeps::SweepSpec& spec, const CaptureOptions& options);

}  // namespace tally::capture
