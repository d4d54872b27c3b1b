// A capture spec: the matrix renderers x scenes x resolutions x counting
// modes x cameras. Parsed with errors that name the field.
#pragma once

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/resolution.hpp"
#include "common/result.hpp"
#include "scenes/heatmap.hpp"
#include "scenes/scene.hpp"
#include "spirv/instrument.hpp"

namespace tally::capture {

// Limits on what one spec may ask for (with kMaxDimension and kMaxPixels per
// frame, common/resolution.hpp). The service tightens them further.
inline constexpr uint32_t kMaxFrames = 1000;
inline constexpr uint32_t kDefaultFrames = 20;  // 20 frames per sample, as in the founding study
inline constexpr uint32_t kDefaultCountedFrames = 2;  // instrumented frames per sample unless the spec says
inline constexpr uint32_t kMaxMatrix = 10000;   // samples (renderers x scenes x resolutions x modes x cameras)
// Entries per list, checked before any entry is (docs/api.md, "Limits"). The
// largest specs in the tree use 9 variants, 2 scenes, 10 resolutions and 4
// cameras; a matrix within these still meets kMaxMatrix and the service's cost.
inline constexpr size_t kMaxVariants = 32;      // renderers and workloads together (each a variant)
inline constexpr size_t kMaxScenes = 32;        // "scenes"
inline constexpr size_t kMaxResolutions = 64;   // "resolutions"
inline constexpr size_t kMaxCameras = 256;      // "cameras" when a list
inline constexpr size_t kMaxModes = 16;         // "counting" when a list
inline constexpr size_t kMaxCameraLabel = 256;  // characters of a camera's "label"
// "footprint": true is this block size; an integer must be one of 32, 64, 128.
inline constexpr uint32_t kDefaultFootprintBlockBytes = 64;

// One measured variant: a renderer and its canonical options
// (renderers::canonicalOptions: defaults dropped, {} for the renderer as it is).
struct RendererVariant {
  std::string name;
  nlohmann::json options = nlohmann::json::object();

  std::string label() const;  // renderers::variantLabel: "forward", "forward output=overdraw"
  // The variant its images are measured against: every set option replaced by
  // its OptionDef reference value (dropped where that is the default). Equal
  // to *this when the variant is its own reference.
  RendererVariant reference() const;
  bool operator==(const RendererVariant&) const = default;
};

struct CaptureSpec {
  // Each entry is a name or {"renderer": NAME, "options": {...}}.
  std::vector<RendererVariant> renderers;
  std::vector<nlohmann::json> scenes;  // each as makeScene() takes it
  std::vector<Resolution> resolutions;
  bool autoCameras = true;
  std::vector<scenes::Camera> cameras;  // when !autoCameras
  // A camera heatmap ("heatmap", replacing "cameras"): the poses are placed
  // per scene when it is loaded (scenes/heatmap.hpp); its samples' cameras
  // carry their cell and its runs' notes the layout.
  std::optional<scenes::HeatmapSpec> heatmap;
  uint32_t frames = kDefaultFrames;
  // Instrumented frames per sample, whose counts are averaged and whose
  // times give the overhead ratio; 0: kDefaultCountedFrames (or `frames`
  // if fewer). A fixed camera counts the same every frame, so 2 catch a
  // count that varies (the sample says counts_vary) at a tenth of the
  // counting time of 20.
  uint32_t countedFrames = 0;
  uint32_t countedFramesOrDefault() const {
    return countedFrames != 0 ? countedFrames : std::min(frames, kDefaultCountedFrames);
  }
  // One run per mode: "counting" is a mode or an array of modes. The
  // uninstrumented baseline is not a mode: every run times it (frame_ms).
  // Default: accumulate, the cheapest exact mode on lavapipe and the H200
  // (docs/accuracy.md, "The accumulate mode").
  std::vector<spirv::Mode> modes = {spirv::Mode{spirv::CountMode::Accumulate}};
  uint32_t lights = 400;  // as in the founding study
  // Footprint counting (docs/measurement.md, "Footprint"; the spec's
  // "footprint"): 0 off, else the block size in bytes (32, 64 or 128) of the
  // bitmaps that mark the distinct blocks each line touches. Instrumented
  // runs only (renderers::RendererOptions::footprintBlockBytes).
  uint32_t footprintBlockBytes = 0;
  // Counts per access site (docs/measurement.md, "Sites, draws and
  // materials"; the spec's "sites"): each pass's bytes per shader source
  // line and per draw. Instrumented runs only (RendererOptions::sites).
  bool sites = false;
  // Measure the device's ceilings (gpu/ceilings.hpp) at the capture's start
  // for the roofline; "ceilings": false skips them (and every pass's
  // roofline then has null fractions of peak).
  bool ceilings = true;
  // The spec's "labels" (parseLabels): what the capture measured, in the
  // user's words ({"commit": "4f2a9c1", "branch": "main"}); stored with the
  // job and shown on its runs. They are not part of a run's configuration.
  std::map<std::string, std::string> labels;
  nlohmann::json source;  // the spec as given, stored with the result

  // Cameras per scene as the matrix limit counts them: automatic 10, a
  // heatmap every pose it may place (empty floor cells are dropped later).
  size_t camerasPerScene() const {
    return heatmap ? heatmap->maxPoses() : autoCameras ? 10 : cameras.size();
  }
  size_t sampleCount(size_t camerasPerScene) const {
    return renderers.size() * scenes.size() * resolutions.size() * modes.size() * camerasPerScene;
  }
  // What the capture renders, in pixel-frames: every sample's frames times
  // its pixels, i.e. frames x (renderers x scenes x modes x cameras) x the
  // sum of the resolutions' pixels. The service bounds it (--max-cost).
  // Saturates at UINT64_MAX rather than wrap.
  uint64_t cost() const {
    uint64_t pixels = 0;
    for (const auto& r : resolutions) pixels += uint64_t(r.width) * r.height;
    uint64_t out = pixels;
    for (uint64_t factor : {uint64_t(frames), uint64_t(renderers.size()), uint64_t(scenes.size()),
                            uint64_t(modes.size()), uint64_t(camerasPerScene())}) {
      if (__builtin_mul_overflow(out, factor, &out)) return UINT64_MAX;
    }
    return out;
  }
};

// The variant of a renderer (or workload) `name` with `options` made
// canonical (renderers::canonicalOptions), as a spec's entry is checked; the
// name is not. Errors begin "options: ..." or "options.output: ...".
Result<RendererVariant> makeVariant(const std::string& name, const nlohmann::json& options);

// A [width, height] as a spec's "resolutions" entry: integers from 1 to
// kMaxDimension, at most kMaxPixels in all; errors name `field`
// ("resolutions[0][1]: must be an integer between 1 and 16384, got 0").
Result<Resolution> parseResolution(const nlohmann::json& r, const std::string& field);

// Labels: at most kMaxLabels keys of 1..kMaxLabelKey characters (letters,
// digits, '_', '-', '.', '/'), each a string of 1..kMaxLabelValue characters
// without control characters. Errors name the label ("labels.commit: ...").
inline constexpr size_t kMaxLabels = 16;
inline constexpr size_t kMaxLabelKey = 64;
inline constexpr size_t kMaxLabelValue = 256;
Result<std::map<std::string, std::string>> parseLabels(const nlohmann::json& labels);

// `knownRenderers` is the list to check names against. Errors read
// "renderers[2]: unknown renderer 'x' (expected one of ...)" or
// "renderers[1].options.output: ...". Cheap whatever the spec holds: the
// lists' lengths are checked first (kMaxVariants, ...), scenes are checked
// without being built (scenes::checkSceneSpec) and nothing is read from
// disk; a repeated entry is refused at its index, naming the first
// ("scenes[3]: repeats scenes[0]").
Result<CaptureSpec> parseCaptureSpec(const nlohmann::json& spec, const std::vector<std::string>& knownRenderers);

// ---- Applications ----------------------------------------------------------------
//
// A spec may instead name an application to capture under the Vulkan layer
// (VK_LAYER_TALLY_counters; docs/layer.md):
//   {"application": {"command": ["vkcube", "--c", "100"], "frames": 10, "skip_frames": 0,
//                    "env": {"K": "V"}, "display": "none", "frame_submits": 0, "name": "cube",
//                    "timeout_s": 300},
//    "counting": "accumulate"}
// or a GFXReconstruct capture replayed under it by gfxrecon-replay:
//   {"replay": "capture.gfxr", "frames": 10, "skip_frames": 0, "display": "none", ...}
// Neither goes with renderers, workloads, scenes, resolutions, cameras or sweep.

inline constexpr uint32_t kDefaultApplicationFrames = 10;
inline constexpr uint32_t kMaxSkipFrames = 100000;
inline constexpr uint32_t kMaxFrameSubmits = 100000;
inline constexpr uint32_t kDefaultApplicationTimeoutSeconds = 300;
inline constexpr uint32_t kMaxApplicationTimeoutSeconds = 3600;
inline constexpr size_t kMaxApplicationArguments = 256;
inline constexpr size_t kMaxApplicationEnv = 64;
inline constexpr size_t kMaxApplicationText = 4096;  // one argument, env value or path
inline constexpr size_t kMaxApplicationName = 128;

struct ApplicationSpec {
  enum class Kind { Application, Replay };
  enum class Display { None, Xvfb };
  Kind kind = Kind::Application;
  // The command as given (argv); empty for a replay.
  std::vector<std::string> command;
  // What runs: command[0] resolved to an absolute path (a bare name looked up
  // on $PATH when parsed); for a replay, "" (gfxrecon-replay is looked up on
  // $PATH when the capture runs).
  std::string program;
  std::string replayFile;  // a replay's file, absolute
  std::string name;        // application.name; "" when not given
  uint32_t frames = kDefaultApplicationFrames;  // frames counted after the skipped ones
  uint32_t skipFrames = 0;
  uint32_t frameSubmits = 0;  // 0: a frame ends at vkQueuePresentKHR; M: M submissions with draws or dispatches
  std::vector<std::pair<std::string, std::string>> env;  // set for the application over tallyd's own
  Display display = Display::None;
  uint32_t timeoutSeconds = kDefaultApplicationTimeoutSeconds;
  std::string counting = "accumulate";  // the layer's modes: accumulate or exact
  bool sites = false;  // the spec's "sites": counts per access site (TALLY_LAYER_SITES), and per draw
  bool draws = false;  // the spec's "draws": counts per draw command alone (TALLY_LAYER_DRAWS)
  nlohmann::json source;                // the spec as given

  // "application." for an application (its fields live in that object), "" for a replay.
  std::string fieldPrefix() const { return kind == Kind::Application ? "application." : ""; }
};

// True for a spec with "application" or "replay" (a JSON object).
bool isApplicationSpec(const nlohmann::json& spec);

// Errors name the field: "application.frames: must be an integer between 1
// and 1000, got 0", "application.env.VK_INSTANCE_LAYERS: ...", "renderers:
// not allowed with "application" ...". A relative replay file, or a
// command[0] with a '/' in it, is taken relative to `baseDir` (the spec
// file's folder; "": the working directory); a bare command[0] is looked up
// on $PATH. The replay file must exist and be readable; the program must be
// an executable file.
Result<ApplicationSpec> parseApplicationSpec(const nlohmann::json& spec, const std::filesystem::path& baseDir = {});

// The first executable file called `name` in the folders of `path` (a
// $PATH-style list; an empty entry is the working directory); "" if none.
std::string findOnPath(const std::string& name, const std::string& path);

}  // namespace tally::capture
