#include "capture/runner.hpp"

#include "capture/sample.hpp"
#include "capture/shader_files.hpp"
#include "capture/screenshot_writer.hpp"

#include <algorithm>
#include <chrono>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <cstdio>
#include <deque>
#include <fstream>
#include <set>
#include <future>
#include <iterator>
#include <map>
#include <optional>

#include "sweeps/headroom.hpp"
#include "analysis/image.hpp"
#include "analysis/stats.hpp"
#include "common/version.hpp"
#include "gpu/ceilings.hpp"
#include "gpu/context.hpp"
#include "gpu/shaders.hpp"
#include "gpu/vk_check.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/options.hpp"
#include "renderers/renderer.hpp"
#include "renderers/scene_limits.hpp"
#include "scenes/cameras.hpp"
#include "scenes/heatmap.hpp"
#include "scenes/spec.hpp"

namespace tally::capture {

using analysis::compareImages;
using sweeps::CounterHeadroom;
using analysis::encodePng;
using analysis::ImageError;
using analysis::Spread;
using analysis::spreadOf;
namespace {

using nlohmann::json;

// A run's notes: the renderer's (an object of its choices), and under
// "scene" what the scene's loader simplified or ignored (Scene::notes).
json runNotes(const renderers::Renderer& renderer, const scenes::Scene& scene, const json& heatmapLayout) {
  json notes = renderer.notes();
  if (!notes.is_object()) notes = json::object();
  // A heatmap's layout: what GET /api/heatmap rebuilds the map from.
  if (!heatmapLayout.is_null()) notes["heatmap"] = heatmapLayout;
  if (!scene.notes.empty()) notes["scene"] = scene.notes;
  // Alpha-tested draws run without early fragment tests, so their depth and
  // stencil writes are derived from the fragments their shaders ran: an upper
  // bound that includes the discarded ones (docs/measurement.md).
  if (scene.features().alphaMask) notes["alpha_mask_depth_writes"] = "upper_bound";
  return notes;
}

// A number from `j[key]`, or nullopt where it is absent or null.
std::optional<double> numberAt(const json& j, const char* key) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return std::nullopt;
  return it->get<double>();
}

json orNull(std::optional<double> v) { return v ? json(*v) : json(nullptr); }

// Each pass's "roofline" (docs/result-schema.md): its estimated arithmetic
// against its bytes (requested: every counted line; footprint: the distinct
// bytes, where the lines carry footprint_bytes) and its uninstrumented time,
// and where that puts it against the device's ceilings (null without them).
void addRoofline(json& sample, const SampleMeasure& m, const json& ceilings) {
  const auto peakBandwidth = ceilings.is_object() ? numberAt(ceilings, "bandwidth_bytes_per_s") : std::nullopt;
  const auto peakOps = ceilings.is_object() ? numberAt(ceilings, "arithmetic_ops_per_s") : std::nullopt;
  for (auto& pass : sample["passes"]) {
    const std::string name = pass["name"].get<std::string>();
    std::optional<double> ops;
    if (auto it = m.arithmeticOps.find(name); it != m.arithmeticOps.end() && !it->second.empty()) {
      ops = spreadOf(it->second).mean;
    }
    const double bytes = numberAt(pass, "bytes").value_or(0);
    // The pass's footprint, or the sum of its lines' where every line has one.
    std::optional<double> footprint = numberAt(pass, "footprint_bytes");
    if (!footprint && !pass["resources"].empty()) {
      double sum = 0;
      bool all = true;
      for (const auto& line : pass["resources"]) {
        auto f = numberAt(line, "footprint_bytes");
        all = all && f.has_value();
        sum += f.value_or(0);
      }
      if (all) footprint = sum;
    }
    const double seconds = numberAt(pass, "gpu_ms").value_or(0) * 1e-3;
    auto ratio = [](std::optional<double> a, std::optional<double> b) -> std::optional<double> {
      if (!a || !b || *b <= 0) return std::nullopt;
      return *a / *b;
    };
    const auto secondsOpt = seconds > 0 ? std::optional<double>(seconds) : std::nullopt;
    const auto intensity = ratio(ops, bytes), intensityFootprint = ratio(ops, footprint);
    const auto bandwidth = ratio(bytes, secondsOpt), bandwidthFootprint = ratio(footprint, secondsOpt);
    const auto opsPerS = ratio(ops, secondsOpt);
    std::optional<double> attainable;
    if (intensity && peakBandwidth && peakOps) {
      attainable = std::min(peakOps.value_or(0.0), *intensity * peakBandwidth.value_or(0.0));
    }
    json bound = nullptr;
    if (intensity && peakBandwidth && peakOps && *peakBandwidth > 0) {
      bound = *intensity < *peakOps / *peakBandwidth ? "memory" : "compute";
    }
    pass["roofline"] = {
        {"arithmetic_ops", orNull(ops)},
        // "counted": executed operations (accumulate mode); "estimated": the static count x invocations.
        {"arithmetic", ops ? json(m.arithmeticCounted.count(name) ? "counted" : "estimated") : json(nullptr)},
        {"bytes_requested", bytes},
        {"footprint_bytes", orNull(footprint)},
        {"intensity_requested", orNull(intensity)},
        {"intensity_footprint", orNull(intensityFootprint)},
        {"ops_per_s", orNull(opsPerS)},
        {"bandwidth_requested", orNull(bandwidth)},
        {"bandwidth_footprint", orNull(bandwidthFootprint)},
        {"fraction_of_peak_bandwidth", orNull(ratio(bandwidth, peakBandwidth))},
        {"fraction_of_peak_bandwidth_footprint", orNull(ratio(bandwidthFootprint, peakBandwidth))},
        {"fraction_of_peak_arithmetic", orNull(ratio(opsPerS, peakOps))},
        {"attainable_ops_per_s", orNull(attainable)},
        {"bound", bound},
    };
  }
}

json resourcesJson(const std::vector<renderers::ResourceInfo>& resources) {
  json out = json::array();
  uint64_t targets = 0;
  for (const auto& r : resources) {
    out.push_back({{"name", r.name},
                   {"kind", std::string(renderers::toString(r.kind))},
                   {"format", r.formatName},
                   {"element_bytes", r.elementBytes},
                   {"width", r.width},
                   {"height", r.height},
                   {"samples", r.samples},
                   {"allocation_bytes", r.allocationBytes},
                   // What the format alone implies (width x height x samples x element bytes).
                   {"format_bytes", uint64_t{r.width} * r.height * r.samples * r.elementBytes},
                   {"usage", r.usage},
                   {"memory", r.memory}});
    bool target = r.kind == renderers::ResourceKind::Attachment || r.kind == renderers::ResourceKind::Depth;
    if (target) targets += r.allocationBytes;
  }
  return {{"list", std::move(out)}, {"render_target_bytes", targets}};
}

json errorJson(const std::string& against, const ImageError& error) {
  return {{"against", against},
          {"psnr", std::isinf(error.psnr) ? json(nullptr) : json(error.psnr)},
          {"identical", std::isinf(error.psnr)},
          {"max_abs", error.maxAbs},
          {"mean_abs", error.meanAbs}};
}

// "deferred" for the renderer as it is, else its options appended
// ("visbuffer_barycentrics-float32"): screenshot names of variants never collide.
std::string fileStem(const RendererVariant& variant) {
  std::string stem = variant.name;
  for (const auto& [key, value] : variant.options.items()) {
    stem += "_" + key + "-" + (value.is_string() ? value.get<std::string>() : value.dump());
  }
  for (char& ch : stem) {
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '-' && ch != '_' && ch != '.') ch = '-';
  }
  return stem;
}

// Where a capture's wall time goes (result "timing", `tallyd capture
// --summary`): seconds per phase, summed over the capture.
class Phases {
 public:
  using Clock = std::chrono::steady_clock;
  void add(const std::string& phase, double seconds) { seconds_[phase] += seconds; }
  // Times the rest of the enclosing scope into `phase`.
  auto scope(const std::string& phase) {
    struct Scope {
      Phases& phases;
      std::string phase;
      Clock::time_point started = Clock::now();
      ~Scope() { phases.add(phase, std::chrono::duration<double>(Clock::now() - started).count()); }
    };
    return Scope{*this, phase};
  }
  void addFrame(const renderers::FrameResult& f, const std::string& prefix) {
    add(prefix + "_frames", f.submitSeconds);
    add(prefix + "_readback", f.readbackSeconds);
  }
  void addSetup(const renderers::Renderer& r, double seconds) {
    auto t = r.setupTimes();
    add("setup_shaders", t.shaderSeconds);
    add("setup_pipelines", t.pipelineSeconds);
    add("setup_other", std::max(0.0, seconds - t.shaderSeconds - t.pipelineSeconds));
  }
  const std::map<std::string, double>& seconds() const { return seconds_; }

 private:
  std::map<std::string, double> seconds_;
};

// Renderer::setup, timed into `phases`.
Result<bool> timedSetup(Phases& phases, renderers::Renderer& r, gpu::Context& ctx, const renderers::GpuScene& scene,
                        const renderers::RendererOptions& options) {
  auto started = Phases::Clock::now();
  auto ok = r.setup(ctx, scene, options);
  phases.addSetup(r, std::chrono::duration<double>(Phases::Clock::now() - started).count());
  return ok;
}

// The final image per camera of `variant`, uninstrumented; empty where it
// cannot be set up (the images are then not compared).
std::vector<std::vector<uint8_t>> referenceImages(gpu::Context& ctx, renderers::GpuScene& gpuScene,
                                                  const RendererVariant& variant, const Resolution& res,
                                                  const std::vector<scenes::Camera>& cameras, const CaptureSpec& spec,
                                                  Phases& phases) {
  auto timed = phases.scope("reference_images");
  std::vector<std::vector<uint8_t>> images;
  auto made = renderers::makeRenderer(variant.name);
  if (!made) return images;
  const renderers::RendererOptions ro = rendererOptions(spec, variant, res, false, spec.modes.front());
  if ((*made)->setup(ctx, gpuScene, ro)) {
    for (const auto& camera : cameras) {
      (*made)->renderFrame(camera);
      images.push_back((*made)->finalImage());
    }
  }
  (*made)->destroy();
  return images;
}

// The images a run's samples are compared with: forward's ("image_error")
// and, for a variant with options, its reference variant's ("variant_error").
struct References {
  std::vector<std::vector<uint8_t>> forward;
  std::string variantAgainst;  // empty: no variant_error
  std::vector<std::vector<uint8_t>> variant;
};

// What every run of one capture shares: the device, the spec and its options,
// the progress, the phase timings, the screenshots and the device's ceilings.
struct CaptureSession {
  gpu::Context& ctx;
  const CaptureSpec& spec;
  const CaptureOptions& options;
  CaptureProgress& progress;
  Phases& phases;
  ScreenshotWriter& screenshots;
  const json& ceilings;
};

// The scene being captured: on the device, its name, its cameras.
struct SceneInCapture {
  renderers::GpuScene& gpuScene;
  const std::string& name;
  const scenes::Scene& scene;
  const SceneCameras& cameras;
};

// One run: a renderer instrumented in one counting mode, each sample's
// instrumented frames timed against the same number of `plain` frames.
Result<json> runOne(CaptureSession& session, const SceneInCapture& current, renderers::Renderer& plain,
                    const RendererVariant& variant, const spirv::Mode& mode, const std::string& where0,
                    const Resolution& res, const References& references) {
  auto& [ctx, spec, options, progress, phases, screenshots, ceilings] = session;
  const auto& [gpuScene, name, scene, sceneCams] = current;
  const std::vector<scenes::Camera>& cameras = sceneCams.cameras;
  const std::string& rendererName = variant.name;
  std::string where = where0 + (spec.modes.size() > 1 ? " " + spirv::toString(mode) : "");
  auto made = renderers::makeRenderer(rendererName);
  if (!made) return makeError(where + ": " + made.error());
  auto& instrumented = *made;
  // Footprint on counted frames only: the plain twin stays as it is.
  const renderers::RendererOptions ro = rendererOptions(spec, variant, res, true, mode);
  auto ok = timedSetup(phases, *instrumented, ctx, gpuScene, ro);
  if (!ok) return makeError(where + ": " + ok.error());
  json run = {{"renderer", rendererName},
              {"options", variant.options},
              {"variant", variant.label()},
              {"scene", name},
              {"scene_params", scene.params},
              {"width", res.width},
              {"height", res.height},
              {"counting", spirv::toString(mode)},
              // The footprint's block size in bytes (docs/result-schema.md); null: footprint off.
              {"footprint_block_bytes", spec.footprintBlockBytes ? json(spec.footprintBlockBytes) : json(nullptr)},
              {"lights", spec.lights},
              {"notes", runNotes(*instrumented, scene, sceneCams.heatmapLayout)},
              {"resources", resourcesJson(instrumented->resources())},
              {"samples", json::array()}};
  // The cost of the instrumentation in the compiled code, where the driver
  // reports it (VK_KHR_pipeline_executable_properties: NVIDIA's register
  // count, local memory): the same passes' pipelines counted and plain.
  if (json counted = instrumented->pipelineStatistics(); !counted.empty()) {
    run["pipeline_statistics"] = {{"instrumented", std::move(counted)}, {"plain", plain.pipelineStatistics()}};
  }
  CounterHeadroom headroom;
  std::set<std::string> siteFiles;  // the shader files the sites' lines are in
  for (size_t c = 0; c < cameras.size(); ++c) {
    const auto& camera = cameras[c];
    progress.current = where + " camera " + std::to_string(c);
    if (options.progress) options.progress(progress);
    SampleMeasure m;
    for (uint32_t f = 0; f < spec.countedFramesOrDefault(); ++f) {
      const renderers::FrameResult frame = instrumented->renderFrame(camera);
      phases.addFrame(frame, "counted");
      headroom.note(frame);
      addCounts(m, frame);
    }
    json extras = instrumented->frameExtras();  // after the sample's last instrumented frame
    for (uint32_t f = 0; f < spec.frames; ++f) {
      const renderers::FrameResult frame = plain.renderFrame(camera);
      phases.addFrame(frame, "timed");
      addTimes(m, frame);
    }
    std::vector<uint8_t> image;
    {
      auto timed = phases.scope("final_image");
      image = plain.finalImage();
    }
    json sample = sampleJson(m, instrumented->resources(), spec.frames, spec.countedFramesOrDefault());
    for (const auto& [pass, sites] : m.sites) {
      for (const auto& s : sites) siteFiles.insert({s.site.site.shader, s.site.site.file});
    }
    addRoofline(sample, m, ceilings);
    sample["camera"] = scenes::toJson(camera);
    sample["camera"]["index"] = c;
    if (c < sceneCams.tags.size()) sample["camera"]["heatmap"] = sceneCams.tags[c];
    // Sky pixels are exactly the skybox pass's fragment invocations (stencil 0, early tests).
    double sky = m.fragmentInvocations.count("skybox") ? spreadOf(m.fragmentInvocations.at("skybox")).mean : -1;
    sample["sky_fraction"] = sky >= 0 ? sky / (double(res.width) * res.height) : -1.0;
    sample["sky_fraction_estimate"] = camera.skyFraction;
    if (!extras.is_object()) extras = json::object();
    addFrameWall(m, extras);
    sample["extras"] = std::move(extras);
    {
      auto timed = phases.scope("image_error");
      // Workloads draw no scene: no image_error against forward (variant_error only).
      if (c < references.forward.size() && !renderers::isWorkload(variant.name)) {
        auto error = compareImages(image, references.forward[c], res.width, res.height);
        if (error) sample["image_error"] = errorJson("forward", *error);
      }
      if (!references.variantAgainst.empty() && c < references.variant.size()) {
        auto error = compareImages(image, references.variant[c], res.width, res.height);
        if (error) sample["variant_error"] = errorJson(references.variantAgainst, *error);
      }
    }
    if (!options.screenshotDir.empty()) {
      // The image is uninstrumented: one screenshot per variant, whatever the modes.
      std::string file = fileStem(variant) + "_" + name + "_" + std::to_string(res.width) + "x" +
                         std::to_string(res.height) + "_cam" + std::to_string(c) + ".png";
      if (&mode == &spec.modes.front()) {
        auto timed = phases.scope("screenshots");  // waiting for a free writer only
        screenshots.write(std::filesystem::path(options.screenshotDir) / file, image, res.width, res.height);
      }
      sample["screenshot"] = file;
    } else {
      sample["screenshot"] = nullptr;
    }
    run["samples"].push_back(std::move(sample));
    ++progress.done;
  }
  instrumented->destroy();
  if (ro.sites) run["shader_sources"] = shaderSources(siteFiles);
  // Counters are zeroed every frame (RendererBase::recordAll): one frame accumulates.
  run["counter_headroom"] = toJson(headroom, gpu::instrumentOptionsFor(ctx, mode).width, 1);
  return run;
}

}  // namespace

Result<json> runSweep(const sweeps::SweepSpec& spec, const CaptureOptions& options) {
  return gpu::withDevice(options.device, [&](gpu::Context& ctx) {
    return sweeps::runSweep(ctx, spec, sweeps::SweepOptions{options.screenshotDir, options.progress});
  });
}

namespace {

Result<json> captureOn(gpu::Context& ctx, const CaptureSpec& spec, const CaptureOptions& options, Phases& phases) {

  json result = {{"device", gpu::describe(ctx)},
                 {"tally", {{"version", std::string(version())}, {"commit", std::string(gitCommit())}}},
                 {"spec", spec.source},
                 {"shaders", shaderHashes()},
                 {"runs", json::array()}};
  if (!options.screenshotDir.empty()) std::filesystem::create_directories(options.screenshotDir);
  // The device's ceilings for the roofline, first (docs/measurement.md,
  // "Device ceilings"). A failure leaves them null with the reason; the
  // capture goes on.
  if (spec.ceilings) {
    auto timed = phases.scope("ceilings");
    auto dir = renderers::shaderDirectory();
    auto ceilings = dir ? gpu::measureCeilings(ctx, *dir) : Result<gpu::Ceilings>(makeError(dir.error()));
    result["device"]["ceilings"] = ceilings ? gpu::toJson(*ceilings) : json(nullptr);
    if (!ceilings) result["device"]["ceilings_error"] = ceilings.error();
  }
  const json ceilings = result["device"].value("ceilings", json(nullptr));

  // Load every scene first: a bad file fails the capture before any GPU time is spent.
  auto loading = Phases::Clock::now();
  auto scenesLoaded = loadScenes(spec, true);
  if (!scenesLoaded) return makeError(scenesLoaded.error());
  std::vector<scenes::Scene> loaded = std::move(scenesLoaded).value();
  phases.add("scene_load", std::chrono::duration<double>(Phases::Clock::now() - loading).count());
  std::vector<SceneCameras> cameras;
  size_t total = 0;
  for (size_t s = 0; s < loaded.size(); ++s) {
    auto placing = Phases::Clock::now();
    cameras.push_back(sceneCameras(spec, loaded[s], spec.scenes[s]));
    phases.add("cameras", std::chrono::duration<double>(Phases::Clock::now() - placing).count());
    if (cameras.back().cameras.empty() && spec.heatmap) {
      return makeError("scenes[" + std::to_string(s) + "] (" + sceneName(spec.scenes[s], loaded[s]) +
                       "): heatmap: no cell has a walkable floor (" + cameras.back().heatmapLayout["empty_counts"].dump() +
                       "); see docs/measurement.md, \"Camera heatmaps\"");
    }
    total += spec.renderers.size() * spec.resolutions.size() * spec.modes.size() * cameras.back().cameras.size();
  }

  ScreenshotWriter screenshots;
  CaptureProgress progress{0, total, ""};
  CaptureSession session{ctx, spec, options, progress, phases, screenshots, ceilings};
  for (size_t s = 0; s < loaded.size(); ++s) {
    renderers::GpuScene gpuScene;
    auto uploading = Phases::Clock::now();
    auto uploaded = gpuScene.upload(ctx, loaded[s]);
    phases.add("scene_upload", std::chrono::duration<double>(Phases::Clock::now() - uploading).count());
    if (!uploaded) return makeError("scenes[" + std::to_string(s) + "]: " + uploaded.error());
    std::string name = sceneName(spec.scenes[s], loaded[s]);
    const SceneInCapture current{gpuScene, name, loaded[s], cameras[s]};

    for (const auto& res : spec.resolutions) {
      // The reference image per camera: forward, uninstrumented.
      References references;
      // None where every variant is a workload (they are not compared with forward).
      if (std::any_of(spec.renderers.begin(), spec.renderers.end(),
                      [](const RendererVariant& v) { return !renderers::isWorkload(v.name); })) {
        references.forward =
            referenceImages(ctx, gpuScene, RendererVariant{"forward", json::object()}, res, cameras[s].cameras, spec, phases);
      }

      for (const auto& variant : spec.renderers) {
        const std::string& rendererName = variant.name;
        std::string where = variant.label() + " " + name + " " + std::to_string(res.width) + "x" + std::to_string(res.height);
        // A variant's images are also measured against its reference variant's.
        RendererVariant referenceVariant = variant.reference();
        references.variantAgainst.clear();
        references.variant.clear();
        if (!variant.options.empty() && referenceVariant != variant) {
          references.variantAgainst = referenceVariant.label();
          references.variant = referenceImages(ctx, gpuScene, referenceVariant, res, cameras[s].cameras, spec, phases);
        }
        // One uninstrumented renderer per variant, timed again beside every mode's run.
        auto plain = renderers::makeRenderer(rendererName);
        if (!plain) return makeError(where + ": " + plain.error());
        const auto plainOptions = rendererOptions(spec, variant, res, false, spec.modes.front());
        auto ok = timedSetup(phases, **plain, ctx, gpuScene, plainOptions);
        if (!ok) return makeError(where + ": " + ok.error());
        for (const auto& mode : spec.modes) {
          auto done = runOne(session, current, **plain, variant, mode, where, res, references);
          if (!done) {
            (*plain)->destroy();
            return makeError(done.error());
          }
          result["runs"].push_back(std::move(done).value());
        }
        (*plain)->destroy();
      }
    }
    gpuScene.destroy();
  }
  {
    auto timed = phases.scope("screenshots");
    if (std::string failed = screenshots.finish(); !failed.empty()) return makeError("cannot write screenshot " + failed);
  }
  progress.current = "done";
  if (options.progress) options.progress(progress);
  return result;
}

}  // namespace

std::string sceneName(const json& spec, const scenes::Scene& scene) {
  if (spec.is_object() && spec.contains("gltf")) {
    return std::filesystem::path(spec["gltf"].get<std::string>()).stem().string();
  }
  return scene.name;
}

renderers::RendererOptions rendererOptions(const CaptureSpec& spec, const RendererVariant& variant,
                                           const Resolution& res, bool instrumented, const spirv::Mode& mode) {
  renderers::RendererOptions ro{{res.width, res.height}, instrumented, mode, spec.lights};
  renderers::applyOptions(variant.options, ro);
  if (instrumented) ro.footprintBlockBytes = spec.footprintBlockBytes;
  ro.sites = ro.draws = instrumented && spec.sites;  // per site, per draw and per material
  return ro;
}

Result<std::vector<scenes::Scene>> loadScenes(const CaptureSpec& spec, bool instrumented) {
  std::vector<scenes::Scene> loaded;
  for (size_t i = 0; i < spec.scenes.size(); ++i) {
    auto scene = scenes::makeScene(spec.scenes[i]);
    if (!scene) return makeError("scenes[" + std::to_string(i) + "]: " + scene.error());
    loaded.push_back(std::move(scene).value());
  }
  // Every (renderer, scene) pair the renderer cannot draw is refused here,
  // before any GPU time is spent (renderers/scene_limits.hpp).
  for (size_t i = 0; i < loaded.size(); ++i) {
    for (const auto& variant : spec.renderers) {
      const auto ro = rendererOptions(spec, variant, spec.resolutions.front(), instrumented, spec.modes.front());
      if (std::string why = renderers::sceneRefusal(variant.name, loaded[i], ro); !why.empty())
        return makeError("scenes[" + std::to_string(i) + "] (" + sceneName(spec.scenes[i], loaded[i]) + "): " + why);
    }
  }
  return loaded;
}

std::vector<scenes::Camera> cameraSet(const CaptureSpec& spec, const scenes::Scene& scene) {
  if (spec.heatmap) return sceneCameras(spec, scene, json(nullptr)).cameras;
  return spec.autoCameras ? scenes::autoCameras(scene) : spec.cameras;
}

SceneCameras sceneCameras(const CaptureSpec& spec, const scenes::Scene& scene, const json& sceneSpec) {
  SceneCameras out;
  if (!spec.heatmap) {
    out.cameras = cameraSet(spec, scene);
    return out;
  }
  scenes::HeatmapPlacement placed = scenes::placeHeatmap(scene, *spec.heatmap);
  for (const auto& pose : placed.poses) {
    out.cameras.push_back(pose.camera);
    out.tags.push_back(scenes::poseJson(pose, *spec.heatmap));
  }
  out.heatmapLayout = std::move(placed.layout);
  out.heatmapLayout["scene"] = sceneSpec;  // what the top-down plan is rendered from
  return out;
}

Result<json> runCapture(const CaptureSpec& spec, const CaptureOptions& options) {
  // Before the device: without shaders nothing can be drawn.
  if (auto dir = renderers::shaderDirectory(); !dir) return makeError(dir.error());
  Phases phases;
  auto started = Phases::Clock::now();
  Phases::Clock::time_point opened;
  auto result = gpu::withDevice(options.device, [&](gpu::Context& ctx) {
    opened = Phases::Clock::now();
    return captureOn(ctx, spec, options, phases);
  });
  if (!result) return result;
  // Seconds per phase; "device" opens (and closes) the Vulkan device, "other"
  // is what no phase names (building the result, spec checks).
  double total = std::chrono::duration<double>(Phases::Clock::now() - started).count();
  double named = 0;
  json timing = json::object();
  for (const auto& [phase, seconds] : phases.seconds()) {
    timing[phase] = seconds;
    named += seconds;
  }
  double device = std::chrono::duration<double>(opened - started).count();
  timing["device"] = device;
  timing["other"] = std::max(0.0, total - named - device);
  timing["total"] = total;
  (*result)["timing"] = std::move(timing);
  return result;
}

}  // namespace tally::capture
