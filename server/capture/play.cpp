#include "capture/play.hpp"

#include "capture/runner.hpp"
#include "gpu/vk_check.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/renderer.hpp"

namespace tally::capture {

using nlohmann::json;

Result<PreparedPlay> preparePlay(const PlaySpec& spec) {
  const CaptureSpec& c = spec.capture;
  if (c.renderers.size() != 1 || c.scenes.size() != 1 || c.resolutions.size() != 1 || c.modes.empty()) {
    return makeError("play: one renderer, one scene and one resolution");
  }
  // The capture's own loading and refusals, as the uninstrumented twin is set up.
  auto loaded = loadScenes(c, false);
  if (!loaded) {
    std::string why = loaded.error();
    if (why.starts_with("scenes[0]")) why = "scene" + why.substr(9);
    return makeError(why);
  }
  PreparedPlay out{spec, std::move(loaded->front()), {}};
  out.cameras = cameraSet(c, out.scene);
  if (spec.camera >= out.cameras.size()) {
    return makeError("camera: " + std::to_string(spec.camera) + " is past the scene's " +
                     std::to_string(out.cameras.size()) + " cameras (0 to " +
                     std::to_string(out.cameras.size() - 1) + ")");
  }
  return out;
}

Result<json> runPlay(const PreparedPlay& play, const PlayOptions& options) {
  if (auto dir = renderers::shaderDirectory(); !dir) return makeError(dir.error());
  const CaptureSpec& c = play.spec.capture;
  const RendererVariant& variant = c.renderers.front();
  const Resolution& res = c.resolutions.front();
  return gpu::withDevice(options.device, [&](gpu::Context& ctx) -> Result<json> {
    if (options.onDevice) options.onDevice(ctx);
    renderers::GpuScene gpuScene;
    auto uploaded = gpuScene.upload(ctx, play.scene);
    if (!uploaded) return makeError("scene: " + uploaded.error());
    auto made = renderers::makeRenderer(variant.name);
    if (!made) return makeError(made.error());
    auto& renderer = **made;
    // The capture's uninstrumented twin, exactly (rendererOptions).
    auto ok = renderer.setup(ctx, gpuScene, rendererOptions(c, variant, res, false, c.modes.front()));
    if (!ok) return makeError(variant.label() + ": " + ok.error());
    if (options.onSetup) options.onSetup(renderer);
    json named = json::array();
    for (const auto& r : renderer.resources()) named.push_back({{"name", r.name}, {"objects", r.objects.size()}});
    json result = {{"renderer", variant.name},
                   {"options", variant.options},
                   {"scene", sceneName(c.scenes.front(), play.scene)},
                   {"width", res.width},
                   {"height", res.height},
                   {"camera", play.spec.camera},
                   {"frames", c.frames},
                   {"passes", renderer.passNames()},
                   {"max_pipeline_sets", renderer.maxPipelineSetCount()},
                   {"debug_utils",
                    {{"names", ctx.setDebugUtilsObjectName != nullptr},
                     {"labels", ctx.cmdBeginDebugUtilsLabel != nullptr}}},
                   {"named", std::move(named)}};
    const scenes::Camera& camera = play.cameras[play.spec.camera];
    for (uint32_t f = 1; f <= c.frames; ++f) {
      const renderers::FrameResult frame = renderer.renderFrame(camera);
      if (options.onFrame) options.onFrame(f, frame);
    }
    renderer.destroy();  // before the scene it draws (and on a throw, by its destructor)
    return result;
  });
}

}  // namespace tally::capture
