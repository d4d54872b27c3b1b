#include "capture/spec.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <system_error>

#include <unistd.h>

#include "renderers/options.hpp"
#include "scenes/cameras.hpp"
#include "scenes/spec.hpp"

namespace tally::capture {
namespace {

std::string show(const nlohmann::json& j) {
  std::string s = j.dump();
  return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

Error fieldError(const std::string& field, const std::string& message) { return makeError(field + ": " + message); }

// "scenes: at most 32 entries, got 40", before any entry is looked at.
std::optional<Error> tooMany(const nlohmann::json& list, const std::string& field, size_t most) {
  if (!list.is_array() || list.size() <= most) return std::nullopt;
  return fieldError(field,
                    "at most " + std::to_string(most) + " entries, got " + std::to_string(list.size()));
}

// "scenes[3]: a duplicate of scenes[0]".
Error duplicate(const std::string& field, const std::string& first) {
  return fieldError(field, "a duplicate of " + first + " (each entry must differ)");
}

Result<uint32_t> boundedInt(const nlohmann::json& j, const std::string& field, uint32_t low, uint32_t high) {
  if (!j.is_number_integer() || j.get<int64_t>() < low || j.get<int64_t>() > high) {
    return fieldError(field, "must be an integer between " + std::to_string(low) + " and " + std::to_string(high) +
                                 ", got " + show(j));
  }
  return static_cast<uint32_t>(j.get<int64_t>());
}

}  // namespace

Result<RendererVariant> makeVariant(const std::string& name, const nlohmann::json& options) {
  if (!options.is_object()) return fieldError("options", "must be an object of option: value, got " + show(options));
  // canonicalOptions' errors begin with the option's name ("output: ...").
  auto canonical = renderers::canonicalOptions(name, options);
  if (!canonical) return makeError("options." + canonical.error());
  return RendererVariant{name, std::move(canonical).value()};
}

Result<Resolution> parseResolution(const nlohmann::json& r, const std::string& field) {
  if (!r.is_array() || r.size() != 2) return fieldError(field, "must be [width, height], got " + show(r));
  auto w = boundedInt(r[0], field + "[0]", 1, kMaxDimension);
  if (!w) return makeError(w.error());
  auto h = boundedInt(r[1], field + "[1]", 1, kMaxDimension);
  if (!h) return makeError(h.error());
  if (uint64_t{*w} * *h > kMaxPixels) {
    return fieldError(field, std::to_string(*w) + "x" + std::to_string(*h) + " is more than the " +
                                 std::to_string(kMaxPixels) + "-pixel limit (8K)");
  }
  return Resolution{*w, *h};
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

Result<CaptureSpec> parseCaptureSpec(const nlohmann::json& j, const std::vector<std::string>& knownRenderers) {
  if (!j.is_object()) return makeError("spec: must be a JSON object, got " + show(j));
  static const std::vector<std::string> kKeys = {"renderers", "workloads",      "scenes",   "resolutions", "cameras",
                                                 "frames",    "counted_frames", "counting", "lights",
                                                 "footprint", "ceilings",       "heatmap", "labels"};
  for (const auto& [key, value] : j.items()) {
    if (std::find(kKeys.begin(), kKeys.end(), key) == kKeys.end()) {
      return fieldError(key,
                        "unknown field (expected renderers, workloads, scenes, resolutions, cameras, frames, "
                        "counted_frames, counting, lights, footprint, ceilings, heatmap, labels)");
    }
  }
  CaptureSpec spec;
  spec.source = j;

  // renderers, then workloads (renderers::workloadNames(): compute workloads,
  // listed only under "workloads"): one variant list. At least one of the two.
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
      std::string field = std::string(list) + "[" + std::to_string(i) + "]";
      const auto& entry = entries[i];
      nlohmann::json options = nlohmann::json::object();
      std::string name;
      if (entry.is_object()) {
        // A workload entry may say "workload" or "renderer".
        const std::string nameKey = workloads && entry.contains("workload") ? "workload" : "renderer";
        for (const auto& [key, value] : entry.items()) {
          if (key != nameKey && key != "options") {
            return fieldError(field + "." + key, "unknown field (expected " + nameKey + ", options)");
          }
        }
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
      field = std::string(list) + "[" + std::to_string(i) + "]";
      auto made = makeVariant(name, options);
      if (!made) return makeError(field + "." + made.error());
      RendererVariant variant = std::move(made).value();
      for (size_t k = 0; k < spec.renderers.size(); ++k) {
        const auto& seen = spec.renderers[k];
        if (seen.name == variant.name && seen.options == variant.options) {
          return fieldError(field, noun + " '" + variant.label() + "' listed twice (a duplicate of " +
                                       variantFields[k] + ")");
        }
      }
      spec.renderers.push_back(std::move(variant));
      variantFields.push_back(field);
    }
  }

  // scenes: their names and parameters are checked here, nothing is built;
  // the capture builds them (and loads glTF files, reporting what is wrong
  // with one as the job's error).
  if (!j.contains("scenes")) {
    spec.scenes.push_back("atrium");  // the default scene
  } else {
    const auto& scenesJson = j["scenes"];
    if (!scenesJson.is_array() || scenesJson.empty()) return fieldError("scenes", "must be a non-empty array");
    if (auto e = tooMany(scenesJson, "scenes", kMaxScenes)) return *e;
    std::vector<nlohmann::json> canonical;
    for (size_t i = 0; i < scenesJson.size(); ++i) {
      const auto& s = scenesJson[i];
      std::string field = "scenes[" + std::to_string(i) + "]";
      if (!s.is_string() && !s.is_object()) {
        return fieldError(field, "must be a scene name or an object, got " + show(s));
      }
      if (s.is_object() && s.contains("gltf") &&
          (!s["gltf"].is_string() || s["gltf"].get<std::string>().empty())) {
        return fieldError(field + ".gltf", "must be a file path");
      }
      auto checked = scenes::checkSceneSpec(s);
      if (!checked) return fieldError(field, checked.error());
      for (size_t k = 0; k < canonical.size(); ++k) {
        if (canonical[k] == *checked) return duplicate(field, "scenes[" + std::to_string(k) + "]");
      }
      canonical.push_back(std::move(checked).value());
      spec.scenes.push_back(s);
    }
  }

  // resolutions
  if (!j.contains("resolutions")) return fieldError("resolutions", "required, e.g. [[1280,720]]");
  const auto& resolutions = j["resolutions"];
  if (!resolutions.is_array() || resolutions.empty()) {
    return fieldError("resolutions", "must be a non-empty array of [width, height]");
  }
  if (auto e = tooMany(resolutions, "resolutions", kMaxResolutions)) return *e;
  for (size_t i = 0; i < resolutions.size(); ++i) {
    std::string field = "resolutions[" + std::to_string(i) + "]";
    auto resolution = parseResolution(resolutions[i], field);
    if (!resolution) return makeError(resolution.error());
    for (size_t k = 0; k < spec.resolutions.size(); ++k) {
      if (spec.resolutions[k].width == resolution->width &&
          spec.resolutions[k].height == resolution->height) {
        return duplicate(field, "resolutions[" + std::to_string(k) + "]");
      }
    }
    spec.resolutions.push_back(*resolution);
  }

  // cameras
  if (j.contains("cameras")) {
    const auto& cameras = j["cameras"];
    if (cameras.is_string()) {
      if (cameras.get<std::string>() != "auto") {
        return fieldError("cameras", "must be \"auto\" or a list of cameras, got " + show(cameras));
      }
    } else {
      if (auto e = tooMany(cameras, "cameras", kMaxCameras)) return *e;
      auto list = scenes::camerasFromJson(cameras);
      if (!list) return makeError("cameras" + (list.error().starts_with("[") ? list.error() : ": " + list.error()));
      if (list->empty()) return fieldError("cameras", "must not be empty");
      // A camera is its pose and lens; the label only names it.
      for (size_t i = 0; i < list->size(); ++i) {
        const scenes::Camera& c = (*list)[i];
        std::string field = "cameras[" + std::to_string(i) + "]";
        if (c.label.size() > kMaxCameraLabel) {
          return fieldError(field + ".label", "at most " + std::to_string(kMaxCameraLabel) + " characters");
        }
        for (size_t k = 0; k < i; ++k) {
          const scenes::Camera& seen = (*list)[k];
          if (seen.eye == c.eye && seen.target == c.target && seen.fovDeg == c.fovDeg &&
              seen.skyFraction == c.skyFraction) {
            return duplicate(field, "cameras[" + std::to_string(k) + "]");
          }
        }
      }
      spec.autoCameras = false;
      spec.cameras = std::move(list).value();
    }
  }

  // heatmap: poses placed per scene, instead of cameras.
  if (j.contains("heatmap")) {
    if (j.contains("cameras")) {
      return fieldError("heatmap", "cannot be combined with \"cameras\" (a heatmap places its own cameras)");
    }
    auto heatmap = scenes::parseHeatmapSpec(j["heatmap"]);
    if (!heatmap) return makeError(heatmap.error());
    spec.heatmap = std::move(heatmap).value();
    spec.autoCameras = false;
  }

  if (j.contains("frames")) {
    auto frames = boundedInt(j["frames"], "frames", 1, kMaxFrames);
    if (!frames) return makeError(frames.error());
    spec.frames = *frames;
  }
  if (j.contains("counted_frames")) {
    // At most the timed frames: the overhead ratio compares the two.
    auto counted = boundedInt(j["counted_frames"], "counted_frames", 1, spec.frames);
    if (!counted) return makeError(counted.error());
    spec.countedFrames = *counted;
  }
  if (j.contains("counting")) {
    // A string (one mode) or a non-empty array of distinct modes.
    const auto& counting = j["counting"];
    if (!counting.is_string() && !(counting.is_array() && !counting.empty())) {
      return fieldError("counting", "must be a mode or a non-empty array of modes, got " + show(counting));
    }
    if (auto e = tooMany(counting, "counting", kMaxModes)) return *e;
    bool single = counting.is_string();
    spec.modes.clear();
    for (size_t i = 0; i < (single ? 1 : counting.size()); ++i) {
      const auto& entry = single ? counting : counting[i];
      std::string field = single ? "counting" : "counting[" + std::to_string(i) + "]";
      if (!entry.is_string()) return fieldError(field, "must be a string, got " + show(entry));
      auto mode = spirv::parseMode(entry.get<std::string>());
      if (!mode) return fieldError(field, mode.error());
      for (size_t k = 0; k < spec.modes.size(); ++k) {
        if (spirv::toString(spec.modes[k]) == spirv::toString(*mode)) {
          return fieldError(field, "mode '" + spirv::toString(*mode) +
                                       "' listed twice (a duplicate of counting[" + std::to_string(k) + "])");
        }
      }
      spec.modes.push_back(*mode);
    }
  }
  if (j.contains("lights")) {
    auto lights = boundedInt(j["lights"], "lights", 0, 400);  // shaders/shared.h kMaxLights
    if (!lights) return makeError(lights.error());
    spec.lights = *lights;
  }
  if (j.contains("ceilings")) {
    if (!j["ceilings"].is_boolean()) return fieldError("ceilings", "must be true or false, got " + show(j["ceilings"]));
    spec.ceilings = j["ceilings"].get<bool>();
  }
  if (j.contains("labels")) {
    auto labels = parseLabels(j["labels"]);
    if (!labels) return makeError(labels.error());
    spec.labels = std::move(labels).value();
  }

  if (j.contains("footprint")) {
    // true: the default block size; false: off; else a block size in bytes.
    const auto& footprint = j["footprint"];
    if (footprint.is_boolean()) {
      spec.footprintBlockBytes = footprint.get<bool>() ? kDefaultFootprintBlockBytes : 0;
    } else if (footprint.is_number_integer() &&
               (footprint.get<int64_t>() == 32 || footprint.get<int64_t>() == 64 || footprint.get<int64_t>() == 128)) {
      spec.footprintBlockBytes = static_cast<uint32_t>(footprint.get<int64_t>());
    } else {
      return fieldError("footprint", "must be true, false or a block size of 32, 64 or 128 bytes, got " + show(footprint));
    }
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

// A string without NUL of 1..maxLength characters (0.. when `empty` is allowed).
Result<std::string> boundedText(const nlohmann::json& j, const std::string& field, size_t maxLength,
                                bool empty = false) {
  if (!j.is_string()) return fieldError(field, "must be a string, got " + show(j));
  std::string text = j.get<std::string>();
  if ((!empty && text.empty()) || text.size() > maxLength || text.find('\0') != std::string::npos) {
    return fieldError(field, "must be " + std::string(empty ? "" : "a non-empty string of ") + "at most " +
                                 std::to_string(maxLength) + " characters without NUL");
  }
  return text;
}

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
      auto v = boundedInt(value, field, 1, kMaxFrames);
      if (!v) return makeError(v.error());
      spec.frames = *v;
    } else if (key == "skip_frames") {
      auto v = boundedInt(value, field, 0, kMaxSkipFrames);
      if (!v) return makeError(v.error());
      spec.skipFrames = *v;
    } else if (key == "frame_submits") {
      auto v = boundedInt(value, field, 0, kMaxFrameSubmits);
      if (!v) return makeError(v.error());
      spec.frameSubmits = *v;
    } else if (key == "timeout_s") {
      auto v = boundedInt(value, field, 1, kMaxApplicationTimeoutSeconds);
      if (!v) return makeError(v.error());
      spec.timeoutSeconds = *v;
    } else if (key == "display") {
      if (value == "none") {
        spec.display = ApplicationSpec::Display::None;
      } else if (value == "xvfb") {
        spec.display = ApplicationSpec::Display::Xvfb;
      } else {
        return fieldError(field, "must be \"none\" or \"xvfb\", got " + show(value));
      }
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
        if (!v) return makeError(v.error());
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
  if (!j.is_object()) return makeError("spec: must be a JSON object, got " + show(j));
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
    const std::string expected =
        "unknown field (expected replay, frames, skip_frames, frame_submits, env, display, timeout_s, counting)";
    for (const auto& [key, value] : j.items()) {
      if (key == "replay" || key == "counting") continue;
      auto taken = common.take(key, value);
      if (!taken) return makeError(taken.error());
      if (!*taken) return fieldError(key, expected);
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
    for (const auto& [key, value] : j.items()) {
      if (key != "application" && key != "counting") {
        return fieldError(key, "unknown field (expected application, counting)");
      }
    }
    const auto& app = j["application"];
    if (!app.is_object()) {
      return fieldError("application", "must be an object with \"command\", got " + show(app));
    }
    const std::string expected =
        "unknown field (expected command, frames, skip_frames, frame_submits, env, display, name, timeout_s)";
    for (const auto& [key, value] : app.items()) {
      if (key == "command") continue;
      if (key == "name") {
        auto name = boundedText(value, "application.name", kMaxApplicationName);
        if (!name) return makeError(name.error());
        spec.name = *name;
        continue;
      }
      auto taken = common.take(key, value);
      if (!taken) return makeError(taken.error());
      if (!*taken) return fieldError("application." + key, expected);
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
      auto arg = boundedText(command[i], "application.command[" + std::to_string(i) + "]", kMaxApplicationText, i > 0);
      if (!arg) return makeError(arg.error());
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
  if (!finished) return makeError(finished.error());

  if (j.contains("counting")) {
    const auto& counting = j["counting"];
    if (counting != "accumulate" && counting != "exact") {
      return fieldError("counting", "must be \"accumulate\" or \"exact\" (the layer's modes), got " + show(counting));
    }
    spec.counting = counting.get<std::string>();
  }
  return spec;
}

}  // namespace tally::capture
