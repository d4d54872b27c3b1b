// Field checks the sweep spec parsers share (common/json_fields.hpp). Every
// error names its field: "resolution[1]: must be an integer from 1 to 16384, got 0".
#pragma once

#include <algorithm>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/json_fields.hpp"

namespace tally::sweeps::fields {

using json_fields::fieldError;
using json_fields::num;
using json_fields::show;

// "resolution": [width, height], integers from `least` (per axis) to
// kMaxDimension and at most kMaxPixels in all, as capture resolutions.
inline Result<Resolution> resolution(const nlohmann::json& r, Resolution least = {1, 1}) {
  return json_fields::resolution(r, "resolution", least, json_fields::RangeWords::kFromTo);
}

// "a, b, c"
std::string joined(const std::vector<std::string>& names);

// Every sweep spec is an object of the keys its sweep knows ("sweep" among
// them): "spec: must be a JSON object", or the first unknown key.
std::optional<Error> specObject(const nlohmann::json& j, const std::vector<std::string>& keys);

// A renderer name the build knows and the sweep can use (one of `allowed`);
// `whyNot` says what the other renderers lack: "'forward' <whyNot> (expected
// one of deferred)".
Result<std::string> rendererName(const nlohmann::json& r, const std::string& field,
                                 const std::vector<std::string>& allowed,
                                 const std::vector<std::string>& knownRenderers, const std::string& whyNot);

// A swept axis: an array of 1 to `most` distinct values (one listed twice
// would only measure its points twice), each read by `item(j[i], "field[i]")`
// (a Result<T>). `what` names the values in the array's message: "must be an
// array of 1 to 64 <what>, got ...".
template <class T, class Item>
Result<std::vector<T>> distinctList(const nlohmann::json& j, const std::string& field, size_t most,
                                    const std::string& what, Item item) {
  if (!j.is_array() || j.empty() || j.size() > most) {
    return fieldError(field,
                      "must be an array of 1 to " + std::to_string(most) + " " + what + ", got " + show(j));
  }
  std::vector<T> out;
  for (size_t i = 0; i < j.size(); ++i) {
    const std::string f = field + "[" + std::to_string(i) + "]";
    Result<T> v = item(j[i], f);
    if (!v) return v.failure();
    if (std::find(out.begin(), out.end(), *v) != out.end()) {
      if constexpr (std::is_floating_point_v<T>) {
        return fieldError(f, num(*v) + " listed twice");
      } else {
        return fieldError(f, std::to_string(*v) + " listed twice");
      }
    }
    out.push_back(*v);
  }
  return out;
}

}  // namespace tally::sweeps::fields
