// Captures an application, or a GFXReconstruct capture replayed by
// gfxrecon-replay, under the Vulkan layer VK_LAYER_TALLY_counters: runs it as
// a child process with the layer's environment (and an Xvfb of its own where
// the spec asks), waits for the layer's output file, stops the application,
// and turns the output into a capture result of one run with one sample per
// frame (docs/result-schema.md, "Applications"; docs/layer.md).
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "capture/spec.hpp"
#include "common/progress.hpp"
#include "common/result.hpp"
#include "common/child_process.hpp"

namespace tally::capture {

// The variables tallyd sets for the application over its own environment:
// the loader's (VK_ADD_LAYER_PATH = layerDir, VK_INSTANCE_LAYERS and
// VK_LOADER_LAYERS_ENABLE = the layer), the layer's configuration
// (TALLY_LAYER_OUTPUT = output, TALLY_LAYER_FRAMES, TALLY_LAYER_SKIP_FRAMES,
// TALLY_LAYER_FRAME_SUBMITS, TALLY_LAYER_COUNTING), then the spec's env.
std::vector<std::pair<std::string, std::string>> layerEnvironment(const ApplicationSpec& spec,
                                                                  const std::filesystem::path& layerDir,
                                                                  const std::filesystem::path& output);

// The run's renderer: "app:" + application.name, else the layer's
// application.name, else the basename of command[0]; "replay:" + the replay
// file's basename. `layerOutput` may be null (before the output exists).
std::string applicationRunName(const ApplicationSpec& spec, const nlohmann::json& layerOutput = nullptr);

// The capture result (docs/result-schema.md) of the layer's output file,
// parsed: one run whose samples are the layer's frames. Fails naming what is
// missing or malformed in the output ("frames[2].passes[0].gpu_ms: must be a
// number") or when fewer frames arrived than the spec asked for.
Result<nlohmann::json> applicationResult(const ApplicationSpec& spec, const nlohmann::json& layerOutput);

struct ApplicationOptions {
  // "[i/3] ..." steps: started, waiting for frames, output written, done.
  std::function<void(const Progress&)> progress;
  // How long the application may take to exit once the layer's output has
  // appeared, before SIGTERM to its process group; and from SIGTERM to SIGKILL.
  std::chrono::milliseconds exitGrace{2000};
  // Where the capture's own temporary folder (the layer's output, Xvfb's log)
  // is made: "" for the system's ($TMPDIR). tallyd capture puts it beside
  // --out, in the worker's job folder, which goes even when the job is killed.
  std::filesystem::path tempRoot;
  // The user the application (or gfxrecon-replay) runs as (tallyd serve
  // --run-as): its temporary folder becomes that user's, and HOME, USER and
  // LOGNAME are that user's. Xvfb, which runs nothing of the spec's, stays
  // this process's. nullopt: this process's user.
  std::optional<jobs::Credentials> runAs;
};

// Runs the capture. Every failure ends only this capture, with one line
// naming the reason: the application exited or crashed before the output
// (its exit status or signal, and the last lines of its stderr), the output is
// not valid JSON or holds fewer frames than asked (how many arrived), the
// deadline (timeout_s), no layer manifest, no gfxrecon-replay or Xvfb.
// Xvfb, where started, is stopped whatever happens.
Result<nlohmann::json> runApplication(const ApplicationSpec& spec, const ApplicationOptions& options = {});

}  // namespace tally::capture
