#include "capture/spec.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <system_error>

#include <unistd.h>

#include "common/json_fields.hpp"
#include "renderers/options.hpp"
#include "scenes/cameras.hpp"
#include "scenes/spec.hpp"

namespace tally::capture {

using json_fields::duplicate;
using json_fields::fieldError;
using json_fields::show;
using json_fields::tooMany;

Result<RendererVariant> makeVariant(const std::string& name, const nlohmann::json& options) {
  if (!options.is_object()) return fieldError("options", "must be an object of option: value, got " + show(options));
  // canonicalOptions' errors name the option ("output").
  auto canonical = renderers::canonicalOptions(name, options);
  if (!canonical) return json_fields::under("options", canonical.failure());
  return RendererVariant{name, std::move(canonical).value()};
}

Result<Resolution> parseResolution(const nlohmann::json& r, const std::string& field) {
  return json_fields::resolution(r, field);
}

std::string RendererVariant::label() const { return renderers::variantLabel(name, options); }

RendererVariant RendererVariant::reference() const {
  RendererVariant out{name, nlohmann::json::object()};
  for (const auto& def : renderers::optionDefs()) {
    if (!options.contains(def.name)) {
      // An unset option joins the reference with its reference value where
      // the technique it belongs to is on (OptionDef::referenceWith).
      if (!def.referenceWith.empty() && options.contains(def.referenceWith) && !def.reference.is_null() &&
          def.reference != def.defaultValue()) {
        out.options[def.name] = def.reference;
      }
      continue;
    }
    if (def.parameter) {
      out.options[def.name] = options[def.name];
      continue;
    }
    const nlohmann::json& value = def.reference.is_null() ? def.defaultValue() : def.reference;
    if (value != def.defaultValue()) out.options[def.name] = value;
  }
  return out;
}

Result<std::map<std::string, std::string>> parseLabels(const nlohmann::json& labels) {
  if (!labels.is_object()) return fieldError("labels", "must be an object of name: text, got " + show(labels));
  if (labels.size() > kMaxLabels) {
    return fieldError("labels", "at most " + std::to_string(kMaxLabels) + " labels, got " + std::to_string(labels.size()));
  }
  std::map<std::string, std::string> out;
  for (const auto& [key, value] : labels.items()) {
    bool nameOk = !key.empty() && key.size() <= kMaxLabelKey &&
                  std::all_of(key.begin(), key.end(), [](char c) {
                    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == '/';
                  });
    if (!nameOk) {
      return fieldError("labels", "label name '" + key.substr(0, kMaxLabelKey) + "' must be 1 to " +
                                      std::to_string(kMaxLabelKey) + " letters, digits, '_', '-', '.' or '/'");
    }
    std::string field = "labels." + key;
    if (!value.is_string()) return fieldError(field, "must be a string, got " + show(value));
    std::string text = value.get<std::string>();
    bool control = std::any_of(text.begin(), text.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20; });
    if (text.empty() || text.size() > kMaxLabelValue || control) {
      return fieldError(field, "must be 1 to " + std::to_string(kMaxLabelValue) +
                                   " characters without control characters");
    }
    out[key] = text;
  }
  return out;
}

namespace {

// renderers, then workloads (renderers::workloadNames(): compute workloads,
// listed only under "workloads"): one variant list. At least one of the two.
std::optional<Error> parseVariants(const nlohmann::json& j, const std::vector<std::string>& knownRenderers,
                                   CaptureSpec& spec) {
  if (!j.contains("renderers") && !j.contains("workloads")) return fieldError("renderers", "required");
  std::vector<std::string> variantFields;  // where each of spec.renderers was given
  for (const char* list : {"renderers", "workloads"}) {
    if (!j.contains(list)) continue;
    const bool workloads = std::string(list) == "workloads";
    const std::vector<std::string> knownNames = workloads ? renderers::workloadNames() : knownRenderers;
    const std::string noun = workloads ? "workload" : "renderer";
    const auto& entries = j[list];
    if (!entries.is_array() || entries.empty()) return fieldError(list, "must be a non-empty array of names");
    if (auto e = tooMany(entries, list, kMaxVariants)) return *e;
    if (spec.renderers.size() + entries.size() > kMaxVariants) {
      return fieldError(list, "at most " + std::to_string(kMaxVariants) +
                                  " renderers and workloads together, got " +
                                  std::to_string(spec.renderers.size() + entries.size()));
    }
    std::string known;
    for (const auto& k : knownNames) known += (known.empty() ? "" : ", ") + k;
    for (size_t i = 0; i < entries.size(); ++i) {
      const std::string entryField = json_fields::index(list, i);
      std::string field = entryField;
      const auto& entry = entries[i];
      nlohmann::json options = nlohmann::json::object();
      std::string name;
      if (entry.is_object()) {
        // A workload entry may say "workload" or "renderer".
        const std::string nameKey = workloads && entry.contains("workload") ? "workload" : "renderer";
        if (auto e = json_fields::unknownKey(entry, field, {nameKey, "options"})) return *e;
        if (!entry.contains(nameKey) || !entry[nameKey].is_string()) {
          return fieldError(field + "." + nameKey, "required: a " + noun + " name");
        }
        name = entry[nameKey].get<std::string>();
        field += "." + nameKey;
        if (entry.contains("options")) options = entry["options"];
      } else if (entry.is_string()) {
        name = entry.get<std::string>();
      } else {
        return fieldError(field, "must be a " + noun + " name or {\"" + noun + "\", \"options\"}, got " + show(entry));
      }
      if (std::find(knownNames.begin(), knownNames.end(), name) == knownNames.end()) {
        if (!workloads && renderers::isWorkload(name)) {
          return fieldError(field, "'" + name + "' is a workload: list it under \"workloads\"");
        }
        if (workloads && std::find(knownRenderers.begin(), knownRenderers.end(), name) != knownRenderers.end()) {
          return fieldError(field, "'" + name + "' is a renderer, not a workload: list it under \"renderers\"");
        }
        return fieldError(field, "unknown " + noun + " '" + name + "' (expected one of " + known + ")");
      }
      auto made = makeVariant(name, options);
      if (!made) return json_fields::under(entryField, made.failure());
      RendererVariant variant = std::move(made).value();
      for (size_t k = 0; k < spec.renderers.size(); ++k) {
        const auto& seen = spec.renderers[k];
        if (seen.name == variant.name && seen.options == variant.options) {
          return fieldError(entryField, noun + " '" + variant.label() + "' listed twice (a duplicate of " +
                                            variantFields[k] + ")");
        }
      }
      spec.renderers.push_back(std::move(variant));
      variantFields.push_back(entryField);
    }
  }
  return std::nullopt;
}

// scenes: their names and parameters are checked here, nothing is built;
// the capture builds them (and loads glTF files, reporting what is wrong
// with one as the job's error).
std::optional<Error> parseScenes(const nlohmann::json& j, CaptureSpec& spec) {
  if (!j.contains("scenes")) {
    spec.scenes.push_back("atrium");  // the default scene
    return std::nullopt;
  }
  const auto& scenesJson = j["scenes"];
  if (!scenesJson.is_array() || scenesJson.empty()) return fieldError("scenes", "must be a non-empty array");
  if (auto e = tooMany(scenesJson, "scenes", kMaxScenes)) return *e;
  std::vector<nlohmann::json> canonical;
  for (size_t i = 0; i < scenesJson.size(); ++i) {
    const auto& s = scenesJson[i];
    std::string field = json_fields::index("scenes", i);
    if (!s.is_string() && !s.is_object()) {
      return fieldError(field, "must be a scene name or an object, got " + show(s));
    }
    if (s.is_object() && s.contains("gltf") &&
        (!s["gltf"].is_string() || s["gltf"].get<std::string>().empty())) {
      return fieldError(field + ".gltf", "must be a file path");
    }
    auto checked = scenes::checkSceneSpec(s);
    // The scene's own message keeps its parameter's name ("scenes[0]: layers: ...").
    if (!checked) return fieldError(field, checked.error());
    for (size_t k = 0; k < canonical.size(); ++k) {
      if (canonical[k] == *checked) return duplicate(field, json_fields::index("scenes", k));
    }
    canonical.push_back(std::move(checked).value());
    spec.scenes.push_back(s);
  }
  return std::nullopt;
}

std::optional<Error> parseResolutions(const nlohmann::json& j, CaptureSpec& spec) {
  if (!j.contains("resolutions")) return fieldError("resolutions", "required, e.g. [[1280,720]]");
  const auto& resolutions = j["resolutions"];
  if (!resolutions.is_array() || resolutions.empty()) {
    return fieldError("resolutions", "must be a non-empty array of [width, height]");
  }
  if (auto e = tooMany(resolutions, "resolutions", kMaxResolutions)) return *e;
  for (size_t i = 0; i < resolutions.size(); ++i) {
    std::string field = json_fields::index("resolutions", i);
    auto resolution = json_fields::resolution(resolutions[i], field);
    if (!resolution) return resolution.failure();
    for (size_t k = 0; k < spec.resolutions.size(); ++k) {
      if (spec.resolutions[k].width == resolution->width &&
          spec.resolutions[k].height == resolution->height) {
        return duplicate(field, json_fields::index("resolutions", k));
      }
    }
    spec.resolutions.push_back(*resolution);
  }
  return std::nullopt;
}

std::optional<Error> parseCameras(const nlohmann::json& cameras, CaptureSpec& spec) {
  if (cameras.is_string()) {
    if (cameras.get<std::string>() == "auto") return std::nullopt;
    return fieldError("cameras", "must be \"auto\" or a list of cameras, got " + show(cameras));
  }
  if (auto e = tooMany(cameras, "cameras", kMaxCameras)) return *e;
  auto list = scenes::camerasFromJson(cameras);
  if (!list) return json_fields::under("cameras", list.failure());
  if (list->empty()) return fieldError("cameras", "must not be empty");
  // A camera is its pose and lens; the label only names it.
  for (size_t i = 0; i < list->size(); ++i) {
    const scenes::Camera& c = (*list)[i];
    std::string field = json_fields::index("cameras", i);
    if (c.label.size() > kMaxCameraLabel) {
      return fieldError(field + ".label", "at most " + std::to_string(kMaxCameraLabel) + " characters");
    }
    for (size_t k = 0; k < i; ++k) {
      const scenes::Camera& seen = (*list)[k];
      if (seen.eye == c.eye && seen.target == c.target && seen.fovDeg == c.fovDeg &&
          seen.skyFraction == c.skyFraction) {
        return duplicate(field, json_fields::index("cameras", k));
      }
    }
  }
  spec.autoCameras = false;
  spec.cameras = std::move(list).value();
  return std::nullopt;
}

// A string (one mode) or a non-empty array of distinct modes.
std::optional<Error> parseCounting(const nlohmann::json& counting, CaptureSpec& spec) {
  if (!counting.is_string() && !(counting.is_array() && !counting.empty())) {
    return fieldError("counting", "must be a mode or a non-empty array of modes, got " + show(counting));
  }
  if (auto e = tooMany(counting, "counting", kMaxModes)) return *e;
  bool single = counting.is_string();
  spec.modes.clear();
  for (size_t i = 0; i < (single ? 1 : counting.size()); ++i) {
    const auto& entry = single ? counting : counting[i];
    std::string field = single ? "counting" : json_fields::index("counting", i);
    auto name = json_fields::text(entry, field);
    if (!name) return name.failure();
    auto mode = spirv::parseMode(*name);
    if (!mode) return fieldError(field, mode.error());
    for (size_t k = 0; k < spec.modes.size(); ++k) {
      if (spirv::toString(spec.modes[k]) == spirv::toString(*mode)) {
        return fieldError(field, "mode '" + spirv::toString(*mode) +
                                     "' listed twice (a duplicate of counting[" + std::to_string(k) + "])");
      }
    }
    spec.modes.push_back(*mode);
  }
  return std::nullopt;
}

// true: the default block size; false: off; else a block size in bytes.
Result<uint32_t> parseFootprint(const nlohmann::json& footprint) {
  if (footprint.is_boolean()) return footprint.get<bool>() ? kDefaultFootprintBlockBytes : 0u;
  if (footprint.is_number_integer() &&
      (footprint.get<int64_t>() == 32 || footprint.get<int64_t>() == 64 || footprint.get<int64_t>() == 128)) {
    return static_cast<uint32_t>(footprint.get<int64_t>());
  }
  return fieldError("footprint",
                    "must be true, false or a block size of 32, 64 or 128 bytes, got " + show(footprint));
}

}  // namespace

Result<CaptureSpec> parseCaptureSpec(const nlohmann::json& j,
                                     const std::vector<std::string>& knownRenderers) {
  if (!j.is_object()) return fieldError("spec", "must be a JSON object, got " + show(j));
  if (auto e = json_fields::unknownKey(
          j, "",
          {"renderers", "workloads", "scenes", "resolutions", "cameras", "frames", "counted_frames",
           "counting", "lights", "footprint", "sites", "ceilings", "heatmap", "labels"})) {
    return *e;
  }
  CaptureSpec spec;
  spec.source = j;
  if (auto e = parseVariants(j, knownRenderers, spec)) return *e;
  if (auto e = parseScenes(j, spec)) return *e;
  if (auto e = parseResolutions(j, spec)) return *e;
  if (j.contains("cameras")) {
    if (auto e = parseCameras(j["cameras"], spec)) return *e;
  }

  // heatmap: poses placed per scene, instead of cameras.
  if (j.contains("heatmap")) {
    if (j.contains("cameras")) {
      return fieldError("heatmap", "cannot be combined with \"cameras\" (a heatmap places its own cameras)");
    }
    auto heatmap = scenes::parseHeatmapSpec(j["heatmap"]);
    if (!heatmap) return heatmap.failure();
    spec.heatmap = std::move(heatmap).value();
    spec.autoCameras = false;
  }

  if (j.contains("frames")) {
    auto frames = json_fields::count(j["frames"], "frames", 1, kMaxFrames);
    if (!frames) return frames.failure();
    spec.frames = *frames;
  }
  if (j.contains("counted_frames")) {
    // At most the timed frames: the overhead ratio compares the two.
    auto counted = json_fields::count(j["counted_frames"], "counted_frames", 1, spec.frames);
    if (!counted) return counted.failure();
    spec.countedFrames = *counted;
  }
  if (j.contains("counting")) {
    if (auto e = parseCounting(j["counting"], spec)) return *e;
  }
  if (j.contains("lights")) {
    auto lights = json_fields::count(j["lights"], "lights", 0, 400);  // shaders/shared.h kMaxLights
    if (!lights) return lights.failure();
    spec.lights = *lights;
  }
  if (j.contains("ceilings")) {
    auto ceilings = json_fields::boolean(j["ceilings"], "ceilings");
    if (!ceilings) return ceilings.failure();
    spec.ceilings = *ceilings;
  }
  if (j.contains("labels")) {
    auto labels = parseLabels(j["labels"]);
    if (!labels) return labels.failure();
    spec.labels = std::move(labels).value();
  }
  if (j.contains("footprint")) {
    auto footprint = parseFootprint(j["footprint"]);
    if (!footprint) return footprint.failure();
    spec.footprintBlockBytes = *footprint;
  }
  if (j.contains("sites")) {
    auto sites = json_fields::boolean(j["sites"], "sites");
    if (!sites) return sites.failure();
    spec.sites = *sites;
  }

  size_t camerasPerScene = spec.camerasPerScene();
  if (spec.sampleCount(camerasPerScene) > kMaxMatrix) {
    return fieldError("spec", "the matrix has " + std::to_string(spec.sampleCount(camerasPerScene)) +
                                  " samples, more than the limit of " + std::to_string(kMaxMatrix));
  }
  return spec;
}

// ---- Applications ----------------------------------------------------------------

namespace {

namespace fs = std::filesystem;

using json_fields::boundedText;

// Names the layer's configuration is made of: the spec cannot set them.
bool reservedName(const std::string& name) {
  return name.starts_with("TALLY_LAYER_") || (name.starts_with("VK_") && name.find("LAYER") != std::string::npos);
}

bool validEnvName(const std::string& name) {
  if (name.empty() || name.size() > 256 || std::isdigit(static_cast<unsigned char>(name[0]))) return false;
  return std::all_of(name.begin(), name.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

fs::path against(const fs::path& baseDir, const std::string& given) {
  fs::path p(given);
  if (p.is_absolute()) return p.lexically_normal();
  std::error_code ec;
  fs::path base = baseDir.empty() ? fs::current_path(ec) : fs::absolute(baseDir, ec);
  return (base / p).lexically_normal();
}

// The fields an application object or a replay spec share.
struct CommonFields {
  ApplicationSpec& spec;
  std::string prefix;  // "application." or ""

  // Returns an error for a bad value of `key`; true when the key was one of these.
  Result<bool> take(const std::string& key, const nlohmann::json& value) {
    const std::string field = prefix + key;
    if (key == "frames") {
      auto v = json_fields::count(value, field, 1, kMaxFrames);
      if (!v) return v.failure();
      spec.frames = *v;
    } else if (key == "skip_frames") {
      auto v = json_fields::count(value, field, 0, kMaxSkipFrames);
      if (!v) return v.failure();
      spec.skipFrames = *v;
    } else if (key == "frame_submits") {
      auto v = json_fields::count(value, field, 0, kMaxFrameSubmits);
      if (!v) return v.failure();
      spec.frameSubmits = *v;
    } else if (key == "timeout_s") {
      auto v = json_fields::count(value, field, 1, kMaxApplicationTimeoutSeconds);
      if (!v) return v.failure();
      spec.timeoutSeconds = *v;
    } else if (key == "display") {
      auto display = json_fields::oneOf(value, field, {"none", "xvfb"});
      if (!display) return display.failure();
      spec.display = *display == "xvfb" ? ApplicationSpec::Display::Xvfb : ApplicationSpec::Display::None;
    } else if (key == "env") {
      if (!value.is_object()) return fieldError(field, "must be an object of NAME: \"value\", got " + show(value));
      if (value.size() > kMaxApplicationEnv) {
        return fieldError(field, "at most " + std::to_string(kMaxApplicationEnv) + " variables, got " +
                                     std::to_string(value.size()));
      }
      for (const auto& [name, text] : value.items()) {
        const std::string at = field + "." + name;
        if (!validEnvName(name)) return fieldError(at, "not a variable name (letters, digits and _)");
        if (reservedName(name)) {
          return fieldError(at, "is set by Tally to load and configure the layer; a spec cannot set it");
        }
        auto v = boundedText(text, at, kMaxApplicationText, true);
        if (!v) return v.failure();
        spec.env.emplace_back(name, *v);
      }
    } else {
      return false;
    }
    return true;
  }

  Result<bool> finish() {
    if (spec.display == ApplicationSpec::Display::Xvfb) {
      for (const auto& [name, value] : spec.env) {
        if (name == "DISPLAY") {
          return fieldError(prefix + "env.DISPLAY", "is set by \"display\": \"xvfb\" (the X server Tally starts)");
        }
      }
    }
    return true;
  }
};

}  // namespace

bool isApplicationSpec(const nlohmann::json& spec) {
  return spec.is_object() && (spec.contains("application") || spec.contains("replay"));
}

std::string findOnPath(const std::string& name, const std::string& path) {
  if (name.empty() || name.find('/') != std::string::npos) return {};
  size_t start = 0;
  while (true) {
    size_t colon = path.find(':', start);
    std::string dir = path.substr(start, colon == std::string::npos ? std::string::npos : colon - start);
    std::error_code ec;
    fs::path candidate = against(dir, name);  // an empty entry: the working directory
    if (fs::is_regular_file(candidate, ec) && access(candidate.c_str(), X_OK) == 0) return candidate.string();
    if (colon == std::string::npos) return {};
    start = colon + 1;
  }
}

Result<ApplicationSpec> parseApplicationSpec(const nlohmann::json& j, const fs::path& baseDir) {
  if (!j.is_object()) return fieldError("spec", "must be a JSON object, got " + show(j));
  ApplicationSpec spec;
  spec.source = j;
  const bool replay = !j.contains("application");
  spec.kind = replay ? ApplicationSpec::Kind::Replay : ApplicationSpec::Kind::Application;
  const std::string what = replay ? "replay" : "application";
  if (!replay && j.contains("replay")) return fieldError("replay", "cannot be combined with \"application\"");
  // The matrix's fields have no meaning for an application: it draws what it draws.
  for (const char* key : {"renderers", "workloads", "scenes", "resolutions", "cameras", "sweep"}) {
    if (j.contains(key)) {
      return fieldError(key, "not allowed with \"" + what + "\": the " + what +
                                 " draws what it draws (drop \"" + key + "\", or capture it in a spec of its own)");
    }
  }
  CommonFields common{spec, spec.fieldPrefix()};

  if (replay) {
    if (auto e = json_fields::unknownKey(j, "",
                                         {"replay", "frames", "skip_frames", "frame_submits", "env",
                                          "display", "timeout_s", "counting", "sites", "draws"})) {
      return *e;
    }
    for (const auto& [key, value] : j.items()) {
      if (key == "replay" || key == "counting") continue;
      auto taken = common.take(key, value);
      if (!taken) return taken.failure();
    }
    auto file = boundedText(j["replay"], "replay", kMaxApplicationText);
    if (!file) return fieldError("replay", "must be the path of a GFXReconstruct capture file, got " + show(j["replay"]));
    fs::path path = against(baseDir, *file);
    std::error_code ec;
    if (!fs::exists(path, ec)) return fieldError("replay", path.string() + ": no such file");
    if (!fs::is_regular_file(path, ec)) return fieldError("replay", path.string() + ": not a file");
    if (std::ifstream in(path, std::ios::binary); !in) return fieldError("replay", path.string() + ": cannot be read");
    spec.replayFile = path.string();
  } else {
    if (auto e = json_fields::unknownKey(j, "", {"application", "counting", "sites", "draws"})) return *e;
    const auto& app = j["application"];
    if (!app.is_object()) {
      return fieldError("application", "must be an object with \"command\", got " + show(app));
    }
    if (auto e = json_fields::unknownKey(
            app, "application",
            {"command", "frames", "skip_frames", "frame_submits", "env", "display", "name", "timeout_s"})) {
      return *e;
    }
    for (const auto& [key, value] : app.items()) {
      if (key == "command") continue;
      if (key == "name") {
        auto name = boundedText(value, "application.name", kMaxApplicationName);
        if (!name) return name.failure();
        spec.name = *name;
        continue;
      }
      auto taken = common.take(key, value);
      if (!taken) return taken.failure();
    }
    if (!app.contains("command")) {
      return fieldError("application.command", "required: the program and its arguments, e.g. [\"vkcube\", \"--c\", \"100\"]");
    }
    const auto& command = app["command"];
    if (!command.is_array() || command.empty()) {
      return fieldError("application.command", "must be a non-empty array of strings, got " + show(command));
    }
    if (command.size() > kMaxApplicationArguments) {
      return fieldError("application.command", "at most " + std::to_string(kMaxApplicationArguments) +
                                                   " arguments, got " + std::to_string(command.size()));
    }
    for (size_t i = 0; i < command.size(); ++i) {
      auto arg =
          boundedText(command[i], json_fields::index("application.command", i), kMaxApplicationText, i > 0);
      if (!arg) return arg.failure();
      spec.command.push_back(*arg);
    }
    const std::string& program = spec.command[0];
    if (program.find('/') == std::string::npos) {
      const char* path = std::getenv("PATH");
      spec.program = findOnPath(program, path ? path : "");
      if (spec.program.empty()) {
        return fieldError("application.command[0]", "'" + program + "' is not an executable in any folder of $PATH");
      }
    } else {
      fs::path resolved = against(baseDir, program);
      std::error_code ec;
      if (!fs::exists(resolved, ec)) return fieldError("application.command[0]", resolved.string() + ": no such file");
      if (!fs::is_regular_file(resolved, ec) || access(resolved.c_str(), X_OK) != 0) {
        return fieldError("application.command[0]", resolved.string() + ": not an executable file");
      }
      spec.program = resolved.string();
    }
  }

  auto finished = common.finish();
  if (!finished) return finished.failure();

  if (j.contains("counting")) {
    auto counting =
        json_fields::oneOf(j["counting"], "counting", {"accumulate", "exact"}, "(the layer's modes)");
    if (!counting) return counting.failure();
    spec.counting = *counting;
  }
  for (auto [key, field] : {std::pair{"sites", &spec.sites}, std::pair{"draws", &spec.draws}}) {
    if (!j.contains(key)) continue;
    auto on = json_fields::boolean(j[key], key);
    if (!on) return on.failure();
    *field = *on;
  }
  return spec;
}

}  // namespace tally::capture
