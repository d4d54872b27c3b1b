// The ingest's readers of single fields of a result (ingest_input.hpp).
#include <algorithm>
#include <cmath>

#include "store/ingest_input.hpp"

namespace tally::store::detail {

using nlohmann::json;
using json_fields::find;

// Width and height from a PNG's IHDR chunk (the signature and IHDR come first).
std::pair<int64_t, int64_t> pngSize(const std::vector<uint8_t>& png, const std::string& path) {
  static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (png.size() < 24 || !std::equal(kSignature, kSignature + 8, png.begin()) || png[12] != 'I' ||
      png[13] != 'H' || png[14] != 'D' || png[15] != 'R') {
    bad(path, "not a PNG image");
  }
  auto be32 = [&](size_t at) {
    return int64_t{png[at]} << 24 | int64_t{png[at + 1]} << 16 | int64_t{png[at + 2]} << 8 |
           int64_t{png[at + 3]};
  };
  return {be32(16), be32(20)};
}

// Per-frame times (frame_ms_frames, gpu_ms_frames): absent (or null), or an
// array of finite, non-negative milliseconds; errors name the entry.
const json* optFrameTimes(const json& object, const char* key, const std::string& path) {
  const json* value = find(object, key);
  if (!value) return nullptr;
  std::string at = path + "." + key;
  if (!value->is_array()) bad(at, "must be an array of milliseconds, got " + value->dump());
  for (size_t i = 0; i < value->size(); ++i) {
    const json& ms = (*value)[i];
    std::string entry = at + "[" + std::to_string(i) + "]";
    if (!ms.is_number()) bad(entry, "must be a number, got " + ms.dump());
    double x = ms.get<double>();
    if (!std::isfinite(x)) bad(entry, "must be finite");
    if (x < 0) bad(entry, "must not be negative, got " + ms.dump());
  }
  return value;
}

// The sample's extras, with "roofline" added where its passes carry one: the
// capture's ceilings and each pass's roofline with its time, kept per run
// (the device row holds only the latest capture's device object) and without
// columns of their own (docs/result-schema.md, "extras.roofline").
json extrasWithRoofline(json extras, const json& sample, const json& ceilings) {
  const json* passes = find(sample, "passes");
  if (!passes || !passes->is_array()) return extras;
  json byPass = json::object();
  for (const auto& pass : *passes) {
    const json* roofline = pass.is_object() ? find(pass, "roofline") : nullptr;
    const json* name = pass.is_object() ? find(pass, "name") : nullptr;
    if (!roofline || !roofline->is_object() || !name || !name->is_string()) continue;
    json entry = *roofline;
    if (const json* ms = find(pass, "gpu_ms")) entry["gpu_ms"] = *ms;
    byPass[name->get<std::string>()] = std::move(entry);
  }
  if (byPass.empty()) return extras;
  if (!extras.is_object()) extras = json::object();
  extras["roofline"] = {{"ceilings", ceilings.is_object() ? ceilings : json(nullptr)}, {"passes", std::move(byPass)}};
  return extras;
}

}  // namespace tally::store::detail
