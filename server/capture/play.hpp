// A renderer as an ordinary Vulkan application (`tallyd play`): set up
// uninstrumented on one scene, resolution and camera of a capture, it renders
// frames and nothing else: no counters, no read-back, no screenshots. Its
// images, buffers and passes carry their result names through
// VK_EXT_debug_utils, so that a layer that instruments any application can
// be checked against the renderer's own counts (`tallyd capture`).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "capture/spec.hpp"
#include "common/result.hpp"
#include "gpu/context.hpp"
#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"

namespace tally::capture {

struct PlaySpec {
  // One renderer (or workload), one scene, one resolution; its frames and
  // lights. Scenes, options and resolution as a capture spec takes them.
  CaptureSpec capture;
  uint32_t camera = 0;  // index into the scene's camera set (cameraSet)
};

// The scene built and its camera set, checked before any GPU work.
struct PreparedPlay {
  PlaySpec spec;
  scenes::Scene scene;
  std::vector<scenes::Camera> cameras;
};

// Builds the scene (a glTF file is loaded), refuses a scene the renderer
// cannot draw and a camera index past the scene's set. Errors name the field:
// "scene: ...", "camera: ...".
Result<PreparedPlay> preparePlay(const PlaySpec& spec);

struct PlayOptions {
  std::string device;  // as gpu::ContextOptions::device
  // The context before the scene is uploaded (tests set Context::debugUtilsHook).
  std::function<void(gpu::Context&)> onDevice;
  // After the renderer's setup, and after each frame (1-based).
  std::function<void(const renderers::Renderer&)> onSetup;
  std::function<void(uint32_t frame, const renderers::FrameResult&)> onFrame;
};

// Opens the device, uploads the scene, sets the renderer up uninstrumented
// and renders spec.capture.frames frames (renderFrame: one submission each).
// Returns {"renderer", "options", "scene", "width", "height", "camera",
// "frames", "passes": [names], "max_pipeline_sets", "debug_utils": {"names",
// "labels"}, "named": [{"name", "objects"}]}. Errors: "device: ..." where it
// cannot be opened, else the renderer's setup failure.
Result<nlohmann::json> runPlay(const PreparedPlay& play, const PlayOptions& options);

}  // namespace tally::capture
