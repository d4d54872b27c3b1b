// Field checks the sweep spec parsers share (common/json_fields.hpp). Every
// error names its field: "resolution[1]: must be an integer from 1 to 16384, got 0".
#pragma once

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

}  // namespace tally::sweeps::fields
