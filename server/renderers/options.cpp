#include "renderers/options.hpp"

#include <algorithm>

namespace tally::renderers {
namespace {

using nlohmann::json;

std::string show(const json& j) {
  std::string s = j.dump();
  return s.size() > 60 ? s.substr(0, 57) + "..." : s;
}

std::string joined(const std::vector<json>& values) {
  std::string out;
  for (const auto& v : values) out += (out.empty() ? "" : ", ") + (v.is_string() ? v.get<std::string>() : v.dump());
  return out;
}

std::vector<OptionDef> makeDefs() {
  std::vector<OptionDef> defs;
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
  defs.push_back({"output",
                  {"forward", "forward-zprepass"},
                  {"shaded", "overdraw", "overshading"},
                  {},
                  nullptr,
                  "What the forward pass outputs besides its shading: nothing more, or 1 per fragment into an "
                  "R32_SFLOAT count target (additive blending) with the depth test off (overdraw: fragments "
                  "rasterized per pixel) or on (overshading: fragments shaded per pixel); the image shows the "
                  "counts as a heat ramp and the sample's extras their per-pixel histogram",
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
  // Bloom is a post chain of RendererBase before tonemap: every renderer takes it.
  const std::vector<std::string> everyRenderer = {"forward", "forward-zprepass", "deferred", "visbuffer",
                                                  "visbuffer-lean"};
  defs.push_back({"bloom",
                  everyRenderer,
                  {"off", "naive", "separable", "bilinear"},
                  {},
                  nullptr,
                  "Bloom: a bright pass into an RGBA16F target, then a Gaussian blur of it added by tonemap: "
                  "naive 2D (N x N fetches per pixel), separable (N per pass, two passes) or separable with "
                  "linear-filtered taps merging weight pairs ((N + 1) / 2 per pass)",
                  "naive",
                  [](RendererOptions& o, const json& v) { o.bloom.blur = *parseBloomBlur(v.get<std::string>()); }});
  defs.push_back({"bloom_taps",
                  everyRenderer,
                  {9, 5, 13, 17, 25},
                  {},
                  nullptr,
                  "Bloom's Gaussian kernel width N (sigma = N / 6, weights normalised to sum 1); N % 4 == 1 so "
                  "the bilinear blur pairs every non-centre weight",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.bloom.taps = v.get<uint32_t>(); }});
  defs.back().parameter = true;
  defs.push_back({"bloom_threshold",
                  everyRenderer,
                  {},
                  {0.0, 64.0},
                  1.0,
                  "HDR luminance above which a pixel blooms (the excess, hue kept, goes to the bloom target)",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.bloom.threshold = v.get<float>(); }});
  defs.back().parameter = true;
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
  for (const auto& [key, value] : options.items()) {
    auto it = std::find_if(own.begin(), own.end(), [&](const OptionDef* d) { return d->name == key; });
    if (it == own.end()) {
      return makeError(key + ": " + std::string(renderer) + " takes no option " + key +
                       (takes.empty() ? " (it takes none)" : " (it takes: " + takes + ")"));
    }
    const OptionDef& def = **it;
    if (!allowed(def, value)) {
      if (!def.range.empty()) {
        return makeError(key + ": must be a number from " + json(def.range[0]).dump() + " to " +
                         json(def.range[1]).dump() + ", got " + show(value));
      }
      return makeError(key + ": " + show(value) + " is not one of " + joined(def.values));
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
