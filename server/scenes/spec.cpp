#include "scenes/spec.hpp"

#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/json_fields.hpp"
#include "scenes/gltf.hpp"
#include "scenes/procedural.hpp"

namespace tally::scenes {
namespace {

constexpr const char* kNames = "\"atrium\", \"planes\", \"sky\" or {\"gltf\": \"path\"}";
constexpr int64_t kMaxTextureSizeLimit = 16384;  // the largest image dimension Vulkan devices commonly allow

using json_fields::fieldError;

// Every key of `spec` must be one of `allowed`.
std::optional<Error> checkKeys(const nlohmann::json& spec, const std::vector<std::string>& allowed,
                               const std::string& kind) {
  return json_fields::unknownKey(spec, "", allowed, "unknown key for " + kind);
}

// Integer field in [lo, hi], or the default when absent.
Result<int64_t> integerField(const nlohmann::json& spec, const char* key, int64_t lo, int64_t hi,
                             int64_t dflt) {
  if (!spec.contains(key)) return dflt;
  return json_fields::integer(spec[key], key, lo, hi);
}

// Number field in (lo, hi] or [lo, hi], or the default when absent.
Result<double> numberField(const nlohmann::json& spec, const char* key, double lo, bool loOpen, double hi,
                           double dflt) {
  if (!spec.contains(key)) return dflt;
  const nlohmann::json& v = spec[key];
  bool ok = v.is_number();
  if (ok) {
    double x = v.get<double>();
    ok = std::isfinite(x) && (loOpen ? x > lo : x >= lo) && x <= hi;
  }
  if (!ok) {
    char range[64];
    std::snprintf(range, sizeof range, "%s%g, %g]", loOpen ? "(" : "[", lo, hi);
    return fieldError(key, std::string("must be a number in ") + range + ", got " + json_fields::show(v));
  }
  return v.get<double>();
}

Result<PlanesParams> planesParams(const nlohmann::json& spec) {
  if (auto e = checkKeys(spec, {"name", "layers", "order", "coverage"}, "scene \"planes\"")) return *e;
  PlanesParams p;
  Result<int64_t> layers = integerField(spec, "layers", 1, kMaxPlaneLayers, p.layers);
  if (!layers) return layers.failure();
  p.layers = int(*layers);
  if (spec.contains("order")) {
    const nlohmann::json& o = spec["order"];
    if (o == "back-to-front")
      p.order = DrawOrder::BackToFront;
    else if (o == "front-to-back")
      p.order = DrawOrder::FrontToBack;
    else
      return fieldError("order",
                        "must be \"back-to-front\" or \"front-to-back\", got " + json_fields::show(o));
  }
  Result<double> coverage = numberField(spec, "coverage", 0.0, true, 1.0, p.coverage);
  if (!coverage) return coverage.failure();
  p.coverage = *coverage;
  return p;
}

Result<SkyParams> skyParams(const nlohmann::json& spec) {
  if (auto e = checkKeys(spec, {"name", "coverage"}, "scene \"sky\"")) return *e;
  SkyParams p;
  Result<double> coverage = numberField(spec, "coverage", 0.0, false, 1.0, p.coverage);
  if (!coverage) return coverage.failure();
  p.coverage = *coverage;
  return p;
}

// A glTF scene's path and options, checked without opening the file.
Result<std::pair<std::string, GltfOptions>> gltfParams(const nlohmann::json& spec) {
  if (auto e = checkKeys(spec, {"gltf", "max_texture_size"}, "a glTF scene")) return *e;
  const nlohmann::json& path = spec["gltf"];
  if (!path.is_string() || path.get<std::string>().empty())
    return fieldError("gltf", "must be a non-empty path string, got " + json_fields::show(path));
  GltfOptions options;
  Result<int64_t> maxSize = integerField(spec, "max_texture_size", 1, kMaxTextureSizeLimit, 0);
  if (!maxSize) return maxSize.failure();
  options.maxTextureSize = uint32_t(*maxSize);
  return std::pair{path.get<std::string>(), options};
}

// What a spec names, checked: a built-in scene and its parameters, or a glTF
// file. Nothing is built or read.
struct Checked {
  enum class Kind { Atrium, Planes, Sky, Gltf } kind = Kind::Atrium;
  PlanesParams planes;
  SkyParams sky;
  std::string path;
  GltfOptions gltf;
};

Result<Checked> check(const nlohmann::json& spec) {
  Checked c;
  if (spec.is_string()) {
    const std::string name = spec.get<std::string>();
    if (name == "planes") {
      c.kind = Checked::Kind::Planes;
    } else if (name == "sky") {
      c.kind = Checked::Kind::Sky;
    } else if (name != "atrium") {
      return makeError("unknown scene " + spec.dump() + ", expected " + kNames);
    }
    return c;
  }
  if (!spec.is_object()) return makeError("must be a scene name or an object, got " + spec.dump());
  if (spec.contains("gltf")) {
    if (spec.contains("name"))
      return fieldError("name", "cannot be combined with gltf (a glTF scene is named after its file)");
    auto params = gltfParams(spec);
    if (!params) return params.failure();
    c.kind = Checked::Kind::Gltf;
    c.path = params->first;
    c.gltf = params->second;
    return c;
  }
  if (!spec.contains("name")) return fieldError("name", "missing, expected " + std::string(kNames));
  const nlohmann::json& name = spec["name"];
  if (name == "atrium") {
    if (auto e = checkKeys(spec, {"name"}, "scene \"atrium\"")) return *e;
    return c;
  }
  if (name == "planes") {
    auto p = planesParams(spec);
    if (!p) return p.failure();
    c.kind = Checked::Kind::Planes;
    c.planes = *p;
    return c;
  }
  if (name == "sky") {
    auto p = skyParams(spec);
    if (!p) return p.failure();
    c.kind = Checked::Kind::Sky;
    c.sky = *p;
    return c;
  }
  return fieldError("name", "unknown scene " + name.dump() + ", expected " + kNames);
}

Result<Scene> makeScene(const nlohmann::json& spec, bool geometryOnly) {
  auto c = check(spec);
  if (!c) return c.failure();
  switch (c->kind) {
    case Checked::Kind::Atrium: return makeAtrium();
    case Checked::Kind::Planes: return makePlanes(c->planes);
    case Checked::Kind::Sky: return makeSky(c->sky);
    case Checked::Kind::Gltf: {
      GltfOptions options = c->gltf;
      options.geometryOnly = geometryOnly;
      Result<Scene> scene = loadGltf(c->path, options);
      if (!scene) return json_fields::under("gltf", scene.failure());
      return scene;
    }
  }
  return makeError("unknown scene kind");
}

}  // namespace

Result<Scene> makeScene(const nlohmann::json& spec) { return makeScene(spec, false); }

Result<nlohmann::json> checkSceneSpec(const nlohmann::json& spec) {
  auto c = check(spec);
  if (!c) return c.failure();
  switch (c->kind) {
    case Checked::Kind::Atrium: return nlohmann::json{{"name", "atrium"}};
    case Checked::Kind::Planes:
      return nlohmann::json{{"name", "planes"},
                            {"layers", c->planes.layers},
                            {"order", toString(c->planes.order)},
                            {"coverage", c->planes.coverage}};
    case Checked::Kind::Sky: return nlohmann::json{{"name", "sky"}, {"coverage", c->sky.coverage}};
    case Checked::Kind::Gltf:
      return nlohmann::json{{"gltf", c->path}, {"max_texture_size", c->gltf.maxTextureSize}};
  }
  return makeError("unknown scene kind");
}
Result<Scene> makeSceneGeometry(const nlohmann::json& spec) { return makeScene(spec, true); }

}  // namespace tally::scenes
