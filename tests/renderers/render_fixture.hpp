// Shared by the renderer tests: one Vulkan device per process
// (TALLY_TEST_DEVICE selects it), scenes uploaded once per spec, and one
// frame rendered by a named renderer with its counts, image and resources.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "gpu/context.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"

namespace tally::renderers::fixture {

constexpr uint32_t kTestLights = 8;  // lavapipe is slow: few lights

struct TestScene {
  scenes::Scene scene;
  std::unique_ptr<GpuScene> gpu;
  scenes::Camera camera;  // the scene's fixed camera, else the automatic one nearest a third sky
};

// The process-wide device; null (and a test failure) when there is none.
gpu::Context* context();

// The scene of `spec`, built and uploaded on first use.
TestScene& testScene(const nlohmann::json& spec);

struct Rendered {
  bool ok = false;  // setup succeeded and a frame was rendered
  std::string error;  // setup's reason otherwise
  FrameResult frame;
  std::vector<uint8_t> image;
  nlohmann::json notes;
  nlohmann::json extras;  // Renderer::frameExtras() of the last frame
  std::vector<ResourceInfo> resources;
};

// One renderer's last of `frames` frames of `spec` from its test camera.
// Setup must succeed unless expectFailure (then `error` holds the reason).
Rendered render(const std::string& name, const nlohmann::json& spec, VkExtent2D extent,
                const std::function<void(RendererOptions&)>& adjust = {}, int frames = 1,
                bool expectFailure = false);

const PassResult& passNamed(const Rendered& r, const std::string& name);

// Counted events on resources whose name starts with `prefix`.
uint64_t counted(const PassResult& p, const std::string& prefix, bool write,
                 const std::string& source = "counter");
// Bytes of the events on the resource named `name`.
uint64_t bytes(const PassResult& p, const std::string& name, bool write, const std::string& source = "counter");

nlohmann::json planes(int layers, const char* order, double coverage = 1.0);
nlohmann::json sky(double coverage);

}  // namespace tally::renderers::fixture
