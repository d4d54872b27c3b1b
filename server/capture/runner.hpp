// Runs a capture spec: one sample per (renderer, scene, resolution, camera).
// See docs/result-schema.md for the result it returns.
#pragma once

#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "capture/spec.hpp"
#include "sweeps/sweep.hpp"
#include "gpu/context.hpp"
#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"
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

// The pieces of a capture that `tallyd play` (capture/play.hpp) shares:
// - the options `variant` is set up with at `res`: counted in `mode` with
//   the spec's footprint, or the uninstrumented twin;
renderers::RendererOptions rendererOptions(const CaptureSpec& spec, const RendererVariant& variant,
                                           const Resolution& res, bool instrumented, const spirv::Mode& mode);
// - every scene of the spec built (glTF files loaded), and every (renderer,
//   scene) pair a renderer cannot draw refused, before any GPU work; errors
//   name the scene ("scenes[1] (sponza): ...");
Result<std::vector<scenes::Scene>> loadScenes(const CaptureSpec& spec, bool instrumented);
// - the cameras a scene is rendered from: the spec's, the scene's automatic
//   set, or a heatmap's poses (placed on the scene's BVH);
std::vector<scenes::Camera> cameraSet(const CaptureSpec& spec, const scenes::Scene& scene);
// - with a heatmap, also each camera's "heatmap" object (its cell) and the
//   layout the runs' notes carry (with the scene's spec as "scene"); empty
//   tags and a null layout otherwise.
struct SceneCameras {
  std::vector<scenes::Camera> cameras;
  std::vector<nlohmann::json> tags;
  nlohmann::json heatmapLayout;
};
SceneCameras sceneCameras(const CaptureSpec& spec, const scenes::Scene& scene, const nlohmann::json& sceneSpec);
// - a scene's name in results: a glTF file's stem, else the scene's own.
std::string sceneName(const nlohmann::json& spec, const scenes::Scene& scene);

}  // namespace tally::capture
