// The check of a sweep result's frame before it is stored (Runs::ingestSweep):
// its name, parameters, threshold, fails_at, plots, and every point carrying
// every parameter and every field its plots name.
#include <string>
#include <vector>

#include "store/ingest_input.hpp"

namespace tally::store::detail {

using json_fields::find;
using nlohmann::json;

namespace {

// The value at a dotted path into a point ("error.max_relative"), or null.
const json* atPath(const json& point, const std::string& dotted) {
  const json* at = &point;
  size_t start = 0;
  while (true) {
    size_t dot = dotted.find('.', start);
    std::string key = dotted.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!at->is_object()) return nullptr;
    at = find(*at, key.c_str());
    if (!at) return nullptr;
    if (dot == std::string::npos) return at;
    start = dot + 1;
  }
}

std::vector<std::string> textList(const json& object, const char* key, const std::string& path) {
  const json* value = find(object, key);
  if (!value || !value->is_array()) bad(path.empty() ? key : path + "." + key, "missing or not an array");
  std::vector<std::string> out;
  for (size_t i = 0; i < value->size(); ++i) {
    std::string at = (path.empty() ? std::string(key) : path + "." + key) + "[" + std::to_string(i) + "]";
    if (!(*value)[i].is_string() || (*value)[i].get<std::string>().empty()) bad(at, "must be a non-empty string");
    out.push_back((*value)[i].get<std::string>());
  }
  return out;
}

bool flag(const json& object, const char* key, const std::string& path) {
  const json* value = find(object, key);
  if (!value) bad(path + "." + key, "missing");
  if (!value->is_boolean()) bad(path + "." + key, "must be true or false");
  return value->get<bool>();
}

}  // namespace

void checkSweep(const json& result) {
  const json* name = find(result, "sweep");
  if (!name || !name->is_string() || name->get<std::string>().empty()) bad("sweep", "missing or not a sweep name");
  std::vector<std::string> parameters = textList(result, "parameters", "");
  if (parameters.empty()) bad("parameters", "must name at least one parameter");
  const json* threshold = find(result, "threshold");
  if (!threshold || !threshold->is_object()) bad("threshold", "missing or not an object");
  if (!result.contains("fails_at")) bad("fails_at", "missing (null when no point reaches the threshold)");
  const json& failsAt = result["fails_at"];
  if (!failsAt.is_null() && !failsAt.is_object() && !failsAt.is_array()) bad("fails_at", "must be an object, an array or null");
  const json* points = find(result, "points");
  if (!points || !points->is_array() || points->empty()) bad("points", "missing, empty or not an array");

  // Every plot names fields of the points; every point must have them.
  struct Plot {
    std::string x, y;
    std::vector<std::string> series;
  };
  std::vector<Plot> plots;
  const json* plotList = find(result, "plots");
  if (!plotList || !plotList->is_array()) bad("plots", "missing or not an array");
  for (size_t i = 0; i < plotList->size(); ++i) {
    std::string at = "plots[" + std::to_string(i) + "]";
    const json& plot = (*plotList)[i];
    if (!plot.is_object()) bad(at, "must be an object");
    kMembers.text(plot, "title", at);
    kMembers.text(plot, "y_label", at);
    flag(plot, "x_log", at);
    flag(plot, "y_log", at);
    if (!plot.contains("threshold")) bad(at + ".threshold", "missing (a number, or null for none)");
    kMembers.optNumber(plot, "threshold", at);
    plots.push_back(
        Plot{kMembers.text(plot, "x", at), kMembers.text(plot, "y", at), textList(plot, "series", at)});
  }
  for (size_t i = 0; i < points->size(); ++i) {
    std::string at = "points[" + std::to_string(i) + "]";
    const json& point = (*points)[i];
    if (!point.is_object()) bad(at, "must be an object");
    // A parameter is a number (distance) or a name (a renderer, a variant).
    for (const auto& parameter : parameters) {
      const json* value = find(point, parameter.c_str());
      if (!value) bad(at + "." + parameter, "missing (every point carries every parameter)");
      if (!value->is_number() && !value->is_string() && !value->is_boolean()) {
        bad(at + "." + parameter, "must be a number or a name, got " + value->dump());
      }
    }
    for (size_t k = 0; k < plots.size(); ++k) {
      std::string named = " (named by plots[" + std::to_string(k) + "])";
      for (const std::string* field : {&plots[k].x, &plots[k].y}) {
        const json* value = atPath(point, *field);
        if (!value) bad(at + "." + *field, "missing" + named);
        if (!value->is_number()) bad(at + "." + *field, "must be a number" + named + ", got " + value->dump());
      }
      for (const auto& field : plots[k].series) {
        if (!atPath(point, field)) bad(at + "." + field, "missing" + named);
      }
    }
  }
}

}  // namespace tally::store::detail
