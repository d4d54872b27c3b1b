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
