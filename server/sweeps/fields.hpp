// Field checks the sweep spec parsers share. Every error names its field:
// "resolution[1]: must be an integer from 1 to 16384, got 0".
#pragma once

#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "common/resolution.hpp"
#include "common/result.hpp"

namespace tally::sweeps::fields {

// The value as compact JSON, cut to 60 characters, for error messages.
std::string show(const nlohmann::json& j);
// "field: message".
Error fieldError(const std::string& field, const std::string& message);
// A number as %g prints it.
std::string num(double v);

// "resolution": [width, height], integers from `least` (per axis) to
// kMaxDimension and at most kMaxPixels in all, as capture resolutions.
Result<Resolution> resolution(const nlohmann::json& r, Resolution least = {1, 1});

}  // namespace tally::sweeps::fields
