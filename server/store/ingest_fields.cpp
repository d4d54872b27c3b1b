// The ingest's readers of single fields of a result (ingest_input.hpp).
#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

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
    if (ms.is_number() && std::isfinite(ms.get<double>()) && ms.get<double>() >= 0) continue;
    std::string entry = at + "[" + std::to_string(i) + "]";  // built only to name what is off
    if (!ms.is_number()) bad(entry, "must be a number, got " + ms.dump());
    if (!std::isfinite(ms.get<double>())) bad(entry, "must be finite");
    bad(entry, "must not be negative, got " + ms.dump());
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

namespace {

bool finiteNumber(const json* v, double& out) {
  if (!v || !v->is_number()) return false;
  out = v->get<double>();
  return std::isfinite(out);
}

// A counter's members, found in one walk (json_fields::findAll).
constexpr std::array<std::string_view, 9> kCounterKeys = {
    "access", "bytes", "count", "count_spread", "footprint_bytes", "format", "kind", "name", "source"};
static_assert(json_fields::inMemberOrder(kCounterKeys));
enum CounterKey { kAccess, kBytes, kCount, kSpread, kFootprint, kFormat, kKind, kName, kSource };
constexpr std::array<std::string_view, 2> kBytesKeys = {"bytes", "footprint_bytes"};
static_assert(json_fields::inMemberOrder(kBytesKeys));

// A counter's bytes and footprint_bytes into `f`, as plainCounter takes them.
bool plainBytes(const json* bytes, const json* footprint, CounterFields& f) {
  if (footprint) {
    double value = 0;
    if (!finiteNumber(footprint, value) || value < 0) return false;
    f.footprint = value;
  }
  return finiteNumber(bytes, f.bytes);
}

// The fields of a well-formed counter, read without building its path
// (counters are most of a result): nothing when any field is not as the
// checked read below takes it, which then names that field.
std::optional<CounterFields> plainCounter(const json& counter) {
  if (!counter.is_object()) return std::nullopt;
  auto m = json_fields::findAll(counter, kCounterKeys);
  CounterFields f;
  if (!plainBytes(m[kBytes], m[kFootprint], f)) return std::nullopt;
  auto text = [&](CounterKey key, std::string_view& out) {
    if (!m[key] || !m[key]->is_string()) return false;
    out = m[key]->get_ref<const std::string&>();
    return true;
  };
  auto optText = [&](CounterKey key, std::optional<std::string_view>& out) {
    if (m[key] && !m[key]->is_string()) return false;
    if (m[key]) out = m[key]->get_ref<const std::string&>();
    return true;
  };
  f.spread = m[kSpread];
  bool plain = (!f.spread || f.spread->is_object()) && finiteNumber(m[kCount], f.count) && text(kAccess, f.access) &&
               (f.access == "read" || f.access == "write") && text(kName, f.name) && optText(kKind, f.kind) &&
               optText(kFormat, f.format) && text(kSource, f.source);
  return plain ? std::optional(f) : std::nullopt;
}

}  // namespace

CounterFields counterFields(const json& counter, const std::string& passPath, size_t c) {
  if (auto plain = plainCounter(counter)) return *plain;
  std::string at = passPath + ".resources[" + std::to_string(c) + "]";
  if (!counter.is_object()) bad(at, "must be an object");
  kMembers.number(counter, "count", at);
  kMembers.number(counter, "bytes", at);
  if (auto footprint = kMembers.optNumber(counter, "footprint_bytes", at); footprint && *footprint < 0)
    bad(at + ".footprint_bytes", "must not be negative");
  std::string access = kMembers.text(counter, "access", at);
  if (access != "read" && access != "write")
    bad(at + ".access", "must be \"read\" or \"write\", got \"" + access + "\"");
  kMembers.text(counter, "name", at);
  kMembers.optText(counter, "kind", at);
  kMembers.optText(counter, "format", at);
  if (const json* spread = find(counter, "count_spread"); spread && !spread->is_object())
    bad(at + ".count_spread", "must be an object (the count over the frames), got " + spread->dump());
  kMembers.text(counter, "source", at);
  throw std::logic_error(at + ": refused by plainCounter, taken by every check");
}

CounterFields counterBytes(const json& counter, const std::string& passPath, size_t c) {
  CounterFields f;
  auto m = json_fields::findAll(counter, kBytesKeys);
  if (counter.is_object() && plainBytes(m[0], m[1], f)) return f;
  return counterFields(counter, passPath, c);
}

ImageErrorColumns imageErrorColumns(const json& sample, const char* key, const std::string& at,
                                    const std::optional<std::string>& defaultAgainst) {
  ImageErrorColumns out;
  const json* error = find(sample, key);
  if (!error) return out;
  std::string errorPath = at + "." + key;
  if (!error->is_object()) bad(errorPath, "must be an object");
  out.against = defaultAgainst ? kMembers.optText(*error, "against", errorPath).value_or(*defaultAgainst)
                               : kMembers.text(*error, "against", errorPath);
  const json* same = find(*error, "identical");
  if (same && !same->is_boolean()) bad(errorPath + ".identical", "must be true or false");
  out.psnr = kMembers.optNumber(*error, "psnr", errorPath);
  out.identical = same ? int64_t{same->get<bool>()} : int64_t{!out.psnr};
  out.maxAbs = kMembers.number(*error, "max_abs", errorPath);
  out.meanAbs = kMembers.number(*error, "mean_abs", errorPath);
  return out;
}

// The lines' sums (ingest_input.hpp): only the two numbers of each line are
// read here; the whole line is read and checked with its pass (addCounters),
// in the same transaction.
CounterSums counterSums(const json& sample, const std::string& path) {
  CounterSums sums;
  const json& passes = kMembers.array(sample, "passes", path);
  for (size_t p = 0; p < passes.size(); ++p) {
    std::string at = path + ".passes[" + std::to_string(p) + "]";
    if (!passes[p].is_object()) bad(at, "must be an object");
    const json& counters = kMembers.array(passes[p], "resources", at);
    for (size_t c = 0; c < counters.size(); ++c) {
      CounterFields n = counterBytes(counters[c], at, c);
      sums.bytes += n.bytes;
      if (n.footprint) {
        sums.footprint = sums.footprint.value_or(0) + *n.footprint;
        sums.footprintRequested = sums.footprintRequested.value_or(0) + n.bytes;
      }
    }
  }
  return sums;
}

}  // namespace tally::store::detail
