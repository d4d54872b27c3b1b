// Renderer options a capture spec may set per renderer: the measured variants
// of a technique ("renderers": [{"renderer": "forward", "options":
// {"output": "overdraw"}}]). One table names every option, the renderers that
// take it, its allowed values (the first is the default) and how it sets
// RendererOptions; spec parsing, the run's stored identity and the API's
// option list all come from it. A technique adds its option here and reads the
// typed field it sets.
#pragma once

#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "renderers/renderer.hpp"

namespace tally::renderers {

struct OptionDef {
  std::string name;                    // the spec's key, e.g. "material_selection"
  std::vector<std::string> renderers;  // renderers that take it
  // Allowed values, the default first. Strings, booleans or integers; where
  // `range` is set instead, any number in [range[0], range[1]].
  std::vector<nlohmann::json> values;
  std::vector<double> range;           // empty, or {min, max}
  nlohmann::json rangeDefault;         // the default where `range` is set
  std::string description;
  // The value counted as the reference when images of variants are compared
  // (e.g. the naive blur for bloom); null: the default.
  nlohmann::json reference;
  std::function<void(RendererOptions&, const nlohmann::json&)> apply;
  // A parameter of a technique (bloom_taps, a map size) rather than the
  // choice of technique: the reference variant keeps the variant's value, so
  // that bloom=separable bloom_taps=13 is compared with bloom=naive
  // bloom_taps=13, not with the naive blur at the default 9 taps.
  bool parameter = false;
  // Where set: the reference variant takes this option's reference value
  // also when the variant leaves it at its default, provided the variant
  // sets the option named here. shadow_map_size (default 2048, reference
  // 4096) names "shadows": shadows=hard is compared with shadows=hard
  // shadow_map_size=4096, while a variant without shadows stays its own reference.
  std::string referenceWith;

  const nlohmann::json& defaultValue() const { return range.empty() ? values.front() : rangeDefault; }
};

// Every option, in a fixed order.
const std::vector<OptionDef>& optionDefs();

// The options `renderer` takes.
std::vector<const OptionDef*> optionsOf(std::string_view renderer);

// Checks `options` (a JSON object) for `renderer` and returns it canonical:
// keys sorted, values equal to their default dropped, so that one variant has
// one stored form ({} for the renderer as it is). Errors name the option:
// "output: 'x' is not one of shaded, overdraw, overshading",
// "zprepass: deferred takes no option zprepass (it takes: ...)".
Result<nlohmann::json> canonicalOptions(std::string_view renderer, const nlohmann::json& options);

// Sets `out`'s typed fields from canonical options.
void applyOptions(const nlohmann::json& canonical, RendererOptions& out);

// "forward" for {}, else "forward output=overdraw zprepass=true" (keys sorted).
std::string variantLabel(std::string_view renderer, const nlohmann::json& canonical);

// The whole table as JSON, for GET /api/renderers and the dashboard's form:
// [{"name", "renderers", "values" | "range", "default", "reference", "description"}].
nlohmann::json optionDefsJson();

}  // namespace tally::renderers
