// A plain-text summary of a capture result: per pass and resource, bytes read
// and written per frame (averaged over samples), totals per renderer, and
// ratios against a baseline renderer.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

namespace tally::capture {

// `baseline`: the renderer the ratios divide by ("" = the first run's).
std::string summarize(const nlohmann::json& result, const std::string& baseline = "");

}  // namespace tally::capture
