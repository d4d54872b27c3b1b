// tallyd play: a renderer as a plain Vulkan application (capture/play.hpp).
#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include "capture/play.hpp"
#include "capture/spec.hpp"
#include "commands/commands.hpp"
#include "gpu/vk_check.hpp"
#include "renderers/renderer.hpp"

namespace tally::cli {
namespace {

using nlohmann::json;

std::string quoted(const std::string& text) { return json(text).dump(); }

// An integer flag from `low` to `high`.
Result<uint32_t> integerFlag(const std::string& flag, const std::string& text, uint32_t low, uint32_t high) {
  uint64_t value = 0;
  auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size() || value < low || value > high) {
    return makeError(flag + ": must be an integer from " + std::to_string(low) + " to " + std::to_string(high) +
                     ", got " + quoted(text));
  }
  return uint32_t(value);
}

// --scene: a name ("atrium"), a spec as JSON ({"name": "planes", "layers": 8}),
// or a glTF file; a relative glTF path is the working directory's.
Result<json> sceneSpec(const std::string& text) {
  if (text.empty()) return makeError("--scene: required (a scene name, a scene spec as JSON, or a .gltf file)");
  json spec;
  if (text.front() == '{' || text.front() == '"') {
    spec = json::parse(text, nullptr, false);
    if (spec.is_discarded()) return makeError("--scene: not valid JSON: " + text);
  } else if (text.ends_with(".gltf") || text.ends_with(".glb")) {
    spec = {{"gltf", text}};
  } else {
    spec = text;
  }
  if (spec.is_object() && spec.contains("gltf") && spec["gltf"].is_string()) {
    const std::filesystem::path given = spec["gltf"].get<std::string>();
    if (given.empty()) return makeError("--scene: gltf: must be a file path");
    spec["gltf"] = std::filesystem::absolute(given).lexically_normal().string();
  }
  return spec;
}

// The spec of the run, every flag checked; errors name the flag.
Result<capture::PlaySpec> playSpec(const PlayArgs& args) {
  capture::PlaySpec play;
  capture::CaptureSpec& spec = play.capture;
  std::vector<std::string> known = renderers::rendererNames();
  for (const auto& w : renderers::workloadNames()) known.push_back(w);
  std::string list;
  for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
  if (args.renderer.empty()) return makeError("--renderer: required (one of " + list + ")");
  if (std::find(known.begin(), known.end(), args.renderer) == known.end()) {
    return makeError("--renderer: unknown renderer " + quoted(args.renderer) + " (expected one of " + list + ")");
  }
  json options = json::object();
  if (!args.options.empty()) {
    options = json::parse(args.options, nullptr, false);
    if (options.is_discarded()) return makeError("--options: not valid JSON: " + args.options);
  }
  auto variant = capture::makeVariant(args.renderer, options);
  if (!variant) {
    // "options: ..." or "options.output: ...": the flag, then the option.
    const std::string& why = variant.error();
    return makeError("--options" + (why.starts_with("options.") ? ": " + why.substr(8) : why.substr(7)));
  }
  spec.renderers = {*variant};

  auto scene = sceneSpec(args.scene);
  if (!scene) return makeError(scene.error());
  spec.scenes = {*scene};

  if (args.resolution.empty()) return makeError("--resolution: required, e.g. 1280x720");
  const size_t x = args.resolution.find('x');
  auto width = integerFlag("--resolution", x == std::string::npos ? "" : args.resolution.substr(0, x), 1, kMaxDimension);
  auto height = integerFlag("--resolution", x == std::string::npos ? "" : args.resolution.substr(x + 1), 1, kMaxDimension);
  if (!width || !height) {
    return makeError("--resolution: must be WIDTHxHEIGHT, each from 1 to " + std::to_string(kMaxDimension) + ", got " +
                     quoted(args.resolution));
  }
  auto resolution = capture::parseResolution(json::array({*width, *height}), "--resolution");
  if (!resolution) return makeError(resolution.error());
  spec.resolutions = {*resolution};

  if (args.frames.empty()) return makeError("--frames: required, e.g. 2");
  auto frames = integerFlag("--frames", args.frames, 1, capture::kMaxFrames);
  if (!frames) return makeError(frames.error());
  spec.frames = *frames;
  auto camera = integerFlag("--camera", args.camera, 0, 1000);
  if (!camera) return makeError(camera.error());
  play.camera = *camera;
  auto lights = integerFlag("--lights", args.lights, 0, 400);  // shaders/shared.h kMaxLights, as a spec's
  if (!lights) return makeError(lights.error());
  spec.lights = *lights;
  spec.source = {{"renderers", json::array({{{"renderer", variant->name}, {"options", variant->options}}})},
                 {"scenes", spec.scenes},
                 {"resolutions", {{resolution->width, resolution->height}}},
                 {"frames", spec.frames},
                 {"lights", spec.lights}};
  return play;
}

}  // namespace

int runPlay(const PlayArgs& args) {
  auto bad = [](const std::string& message) {
    std::cerr << "tallyd play: " << message << "\n";
    return 2;
  };
  auto fail = [](const std::string& message) {
    std::cerr << "tallyd play: " << message << "\n";
    return 1;
  };
  auto spec = playSpec(args);
  if (!spec) return bad(spec.error());
  auto prepared = capture::preparePlay(*spec);  // the scene (and a glTF file) before any GPU work
  if (!prepared) return bad("--" + prepared.error());  // "scene: ...", "camera: ..."

  const gpu::Context* context = nullptr;
  capture::PlayOptions options;
  options.device = args.device;
  options.onDevice = [&context](gpu::Context& ctx) { context = &ctx; };
  options.onSetup = [&](const renderers::Renderer& r) {
    if (!args.verbose) return;
    const bool names = context != nullptr && context->setDebugUtilsObjectName != nullptr;
    const bool labels = context != nullptr && context->cmdBeginDebugUtilsLabel != nullptr;
    std::cerr << "tallyd play: " << r.name() << " set up: " << r.passNames().size() << " passes, "
              << r.resources().size() << " resources; pipeline layouts of at most " << r.maxPipelineSetCount()
              << " descriptor sets; debug utils names " << (names ? "on" : "off") << ", labels "
              << (labels ? "on" : "off") << "\n";
  };
  const uint32_t frames = spec->capture.frames;
  options.onFrame = [&](uint32_t frame, const renderers::FrameResult& result) {
    if (args.quiet) return;
    char line[160];
    std::snprintf(line, sizeof line, "tallyd play: frame %u/%u, %zu passes, %.3f ms\n", frame, frames,
                  result.passes.size(), result.submitSeconds * 1e3);
    std::cerr << line;
  };
  Result<json> result = makeError("not run");
  try {
    result = capture::runPlay(*prepared, options);
  } catch (const gpu::VulkanError& e) {
    return fail(std::string("Vulkan error: ") + e.what());
  } catch (const std::exception& e) {
    return fail(std::string("play failed: ") + e.what());
  }
  if (!result) {
    // A device selector that matches none is bad input; anything else failed on the device.
    if (result.error().starts_with("device: no Vulkan device matches")) return bad("--" + result.error());
    return fail(result.error());
  }
  if (args.json) std::cout << result->dump() << "\n";
  return 0;
}

}  // namespace tally::cli
