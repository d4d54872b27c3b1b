#include "renderers/options.hpp"

#include <algorithm>

#include "common/json_fields.hpp"
#include "renderers/techniques/shadows.hpp"
#include "renderers/techniques/tbn.hpp"
#include "renderers/workloads/workloads.hpp"

namespace tally::renderers {
namespace {

using nlohmann::json;

using json_fields::fieldError;
using json_fields::show;

std::string joined(const std::vector<json>& values) {
  std::string out;
  for (const auto& v : values) out += (out.empty() ? "" : ", ") + (v.is_string() ? v.get<std::string>() : v.dump());
  return out;
}

// Every renderer, for the options they all take (a function, not a global:
// optionDefs() may run during another file's static initialisation).
std::vector<std::string> everyRenderer() {
  return {"forward", "forward-zprepass", "deferred", "visbuffer", "visbuffer-lean"};
}

// How the visibility buffers pick materials and store what the shading pass reads.
void addVisibilityBufferOptions(std::vector<OptionDef>& defs) {
  defs.push_back({"material_selection",
                  {"visbuffer", "visbuffer-lean"},
                  {"nonuniform", "uniform", "first-lane"},
                  {},
                  nullptr,
                  "How the shading pass picks a pixel's material maps: nonuniformEXT (correct), without the "
                  "qualifier as the founding study did (needs descriptor indexing), or the first lane's "
                  "(a scalarising driver's artefact, modelled)",
                  nullptr,
                  [](RendererOptions& o, const json& v) {
                    o.materialSelection = *parseMaterialSelection(v.get<std::string>());
                  }});
  defs.push_back({"barycentrics",
                  {"visbuffer"},
                  {"unorm16", "float32"},
                  {},
                  nullptr,
                  "How the visibility target stores barycentrics: packUnorm2x16 (R32G32_UINT with the id) or "
                  "float32 bits",
                  "float32",
                  [](RendererOptions& o, const json& v) {
                    o.visibility.barycentrics = *parseBarycentricEncoding(v.get<std::string>());
                  }});
  defs.push_back({"uv_derivatives",
                  {"visbuffer"},
                  {"half", "unorm16-clamped", "float32"},
                  {},
                  nullptr,
                  "How the visibility pass stores dFdx(uv), dFdy(uv): packHalf2x16, the founding study's "
                  "packUnorm2x16 (negative components clamp to 0), or float32 bits",
                  "float32",
                  [](RendererOptions& o, const json& v) {
                    o.visibility.uvDerivatives = *parseUvDerivativeEncoding(v.get<std::string>());
                  }});
}

// The pass structure of the forward and deferred renderers.
void addForwardAndDeferredOptions(std::vector<OptionDef>& defs) {
  defs.push_back({"output",
                  {"forward", "forward-zprepass"},
                  {"shaded", "overdraw", "overshading", "density"},
                  {},
                  nullptr,
                  "What the forward pass outputs besides its shading: nothing more, or 1 per fragment into an "
                  "R32_SFLOAT count target (additive blending) with the depth test off (overdraw: fragments "
                  "rasterized per pixel) or on (overshading: fragments shaded per pixel); the image shows the "
                  "counts as a heat ramp and the sample's extras their per-pixel histogram; density colours each "
                  "fragment by its triangle's screen-space class (sub-pixel, long-thin, normal) and measures quad "
                  "lanes (helpers included) per covered pixel",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.forwardOutput = *parseForwardOutput(v.get<std::string>()); }});
  defs.push_back({"zprepass",
                  {"forward", "deferred"},
                  {false, true},
                  {},
                  nullptr,
                  "A depth-only pre-pass before the geometry pass, which then tests depth EQUAL without writing "
                  "it, so each covered pixel is shaded once (forward with it is forward-zprepass)",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.zprepass = v.get<bool>(); }});
  defs.push_back({"gbuffer",
                  {"deferred"},
                  {"sampled", "subpass"},
                  {},
                  nullptr,
                  "How the lighting pass reads the G-buffer: sampled (two render passes, combined image samplers) "
                  "or subpass (one render pass, two subpasses: transient, lazily allocated G-buffer attachments "
                  "with storeOp DONT_CARE read by subpassLoad, so a tile-based GPU keeps them on chip)",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.gbufferSubpass = v.get<std::string>() == "subpass"; }});
}

// Bloom is a post chain of RendererBase before tonemap: every renderer takes it.
void addBloomOptions(std::vector<OptionDef>& defs) {
  defs.push_back({"bloom",
                  everyRenderer(),
                  {"off", "naive", "separable", "bilinear"},
                  {},
                  nullptr,
                  "Bloom: a bright pass into an RGBA16F target, then a Gaussian blur of it added by tonemap: "
                  "naive 2D (N x N fetches per pixel), separable (N per pass, two passes) or separable with "
                  "linear-filtered taps merging weight pairs ((N + 1) / 2 per pass)",
                  "naive",
                  [](RendererOptions& o, const json& v) { o.bloom.blur = *parseBloomBlur(v.get<std::string>()); }});
  defs.push_back({"bloom_taps",
                  everyRenderer(),
                  {9, 5, 13, 17, 25},
                  {},
                  nullptr,
                  "Bloom's Gaussian kernel width N (sigma = N / 6, weights normalised to sum 1); N % 4 == 1 so "
                  "the bilinear blur pairs every non-centre weight",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.bloom.taps = v.get<uint32_t>(); }});
  defs.back().parameter = true;
  defs.push_back({"bloom_threshold",
                  everyRenderer(),
                  {},
                  {0.0, 64.0},
                  1.0,
                  "HDR luminance above which a pixel blooms (the excess, hue kept, goes to the bloom target)",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.bloom.threshold = v.get<float>(); }});
  defs.back().parameter = true;
}

// Levels of detail of the geometry, and how the full-screen shading pass samples and runs.
void addDetailAndShadingOptions(std::vector<OptionDef>& defs) {
  defs.push_back({"lod",
                  everyRenderer(),
                  {"off", 0.5, 1, 2, 4, 8},
                  {},
                  nullptr,
                  "Levels of detail (meshoptimizer's simplifier, borders locked, index count halved per level): "
                  "off, or a pixel threshold: per draw and frame, the coarsest level whose geometric error "
                  "projected at the draw's bounding sphere stays at most this many pixels",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.lodThresholdPx = v.is_string() ? 0.0f : v.get<float>(); }});
  defs.push_back({"msaa",
                  {"deferred", "visbuffer", "visbuffer-lean"},
                  {1, 2, 4, 8},
                  {},
                  nullptr,
                  "MSAA sample count of the geometry pass's targets and depth (G-buffer, or visibility ids and "
                  "barycentrics/derivatives); the shading pass fetches every sample, shades the covered ones "
                  "(deferred: per sample; visibility buffers: per distinct triangle) and averages them into the "
                  "1-sample HDR target. Counts the device lacks are refused at setup",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.msaa = v.get<uint32_t>(); }});
  defs.push_back({"shading",
                  {"deferred", "visbuffer", "visbuffer-lean"},
                  {"fragment", "compute"},
                  {},
                  nullptr,
                  "How the full-screen shading pass (deferred's lighting, the visibility buffers' shading) runs: a "
                  "fragment pass masked by stencil, or a compute dispatch (8x8 workgroups, one invocation per "
                  "pixel) with the same shading code that writes the HDR target with imageStore, sky pixels "
                  "included (the cleared value). Not with msaa > 1 or gbuffer=subpass",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.computeShading = v.get<std::string>() == "compute"; }});
}

// Shadow mapping (renderers/techniques/shadows.hpp): every renderer shades with it.
void addShadowOptions(std::vector<OptionDef>& defs) {
  defs.push_back({"shadows",
                  everyRenderer(),
                  {"off", "hard", "pcf2x2", "pcf4x4"},
                  {},
                  nullptr,
                  "Shadow mapping of one directional sun (orthographic map fitted to the scene bounds, a depth-only "
                  "\"shadow\" pass): hard (one nearest depth-compare tap), pcf2x2 (one linear compare tap: hardware "
                  "2x2 PCF) or pcf4x4 (four linear compare taps at +-1 texel: 4x4 texels); off: no sun, no pass",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.shadows.filter = *parseShadowFilter(v.get<std::string>()); }});
  // A parameter: map-size variants are compared with the same filter at 4096.
  defs.back().parameter = true;
  defs.push_back({"shadow_map_size",
                  everyRenderer(),
                  {2048, 512, 1024, 4096},
                  {},
                  nullptr,
                  "Texels per side of the D32_SFLOAT shadow map (with shadows on)",
                  4096,
                  [](RendererOptions& o, const json& v) { o.shadows.mapSize = v.get<uint32_t>(); }});
  defs.back().referenceWith = "shadows";
  defs.push_back({"shadow_bias",
                  everyRenderer(),
                  {},
                  {0.0, 8.0},
                  1.5,
                  "Shadow depth bias in shadow-map texels (the world size of one texel), times 1 + tan of the "
                  "surface's angle to the sun (slope-scaled, tan capped at 4)",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.shadows.bias = v.get<float>(); }});
  defs.back().parameter = true;
}

// How vertices are laid out in their buffers.
void addVertexOptions(std::vector<OptionDef>& defs) {
  defs.push_back({"tangent_frame",
                  everyRenderer(),
                  {"float", "quaternion"},
                  {},
                  nullptr,
                  "How vertices carry their tangent frame: float normal and tangent (48-byte vertices), or a "
                  "packed 24-byte vertex buffer with the frame as a 24-bit smallest-three unit quaternion "
                  "(bitangent sign in the largest component's sign), read by every vertex path",
                  nullptr,
                  [](RendererOptions& o, const json& v) {
                    o.tangentFrame = *parseTangentFrameEncoding(v.get<std::string>());
                  }});
}

// Every option, in the order /api/options lists them and applyOptions applies them.
std::vector<OptionDef> makeDefs() {
  std::vector<OptionDef> defs;
  addVisibilityBufferOptions(defs);
  addForwardAndDeferredOptions(defs);
  addBloomOptions(defs);
  addDetailAndShadingOptions(defs);
  addShadowOptions(defs);
  addVertexOptions(defs);
  addWorkloadOptions(defs);  // volume-fog, raytrace (workloads.cpp)
  return defs;
}

bool allowed(const OptionDef& def, const json& value) {
  if (!def.range.empty()) {
    return value.is_number() && value.get<double>() >= def.range[0] && value.get<double>() <= def.range[1];
  }
  // Integers compare across signedness (json 4 == json 4u); 4.0 is not 4.
  return std::any_of(def.values.begin(), def.values.end(), [&](const json& v) {
    if (v.is_number_integer() != value.is_number_integer()) return false;
    return v == value;
  });
}

}  // namespace

const std::vector<OptionDef>& optionDefs() {
  static const std::vector<OptionDef> defs = makeDefs();
  return defs;
}

std::vector<const OptionDef*> optionsOf(std::string_view renderer) {
  std::vector<const OptionDef*> out;
  for (const auto& def : optionDefs()) {
    if (std::find(def.renderers.begin(), def.renderers.end(), renderer) != def.renderers.end()) out.push_back(&def);
  }
  return out;
}

Result<json> canonicalOptions(std::string_view renderer, const json& options) {
  if (!options.is_object()) return makeError("must be an object of option: value, got " + show(options));
  const auto own = optionsOf(renderer);
  std::string takes;
  for (const auto* def : own) takes += (takes.empty() ? "" : ", ") + def->name;
  json out = json::object();  // nlohmann's object keeps keys sorted
  for (const auto& item : options.items()) {
    // Not a structured binding: clang before 16 cannot capture one in a lambda.
    const std::string& key = item.key();
    const json& value = item.value();
    auto it = std::find_if(own.begin(), own.end(), [&](const OptionDef* d) { return d->name == key; });
    if (it == own.end()) {
      return fieldError(key, std::string(renderer) + " takes no option " + key +
                                 (takes.empty() ? " (it takes none)" : " (it takes: " + takes + ")"));
    }
    const OptionDef& def = **it;
    if (!allowed(def, value)) {
      if (!def.range.empty()) {
        return fieldError(key, "must be a number from " + json(def.range[0]).dump() + " to " +
                                   json(def.range[1]).dump() + ", got " + show(value));
      }
      return fieldError(key, show(value) + " is not one of " + joined(def.values));
    }
    if (value != def.defaultValue()) out[key] = value;
  }
  return out;
}

void applyOptions(const json& canonical, RendererOptions& out) {
  for (const auto& def : optionDefs()) {
    if (canonical.contains(def.name)) def.apply(out, canonical[def.name]);
  }
}

std::string variantLabel(std::string_view renderer, const json& canonical) {
  std::string label(renderer);
  for (const auto& [key, value] : canonical.items()) {
    label += " " + key + "=" + (value.is_string() ? value.get<std::string>() : value.dump());
  }
  return label;
}

json optionDefsJson() {
  json out = json::array();
  for (const auto& def : optionDefs()) {
    json d = {{"name", def.name},
              {"renderers", def.renderers},
              {"default", def.defaultValue()},
              {"reference", def.reference.is_null() ? def.defaultValue() : def.reference},
              {"parameter", def.parameter},
              {"description", def.description}};
    if (def.range.empty()) {
      d["values"] = def.values;
    } else {
      d["range"] = def.range;
    }
    out.push_back(std::move(d));
  }
  return out;
}

}  // namespace tally::renderers
