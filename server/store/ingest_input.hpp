// What the ingest's files share to read a result (ingest.cpp, ingest_capture.cpp, sweep_frame.cpp):
// bad input throws IngestError naming the JSON path, and the ingest's
// transaction then rolls back.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/json_fields.hpp"
#include "store/db.hpp"

namespace tally::store::detail {

struct IngestError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

[[noreturn]] inline void bad(const std::string& path, const std::string& what) {
  throw IngestError(path + ": " + what);
}

// Members of the result: a fault throws IngestError naming the path.
inline constexpr json_fields::Members kMembers{[](const Error& error) { throw IngestError(error.text()); }};

// Width and height from a PNG's IHDR chunk; `path` names it in errors.
std::pair<int64_t, int64_t> pngSize(const std::vector<uint8_t>& png, const std::string& path);

// Per-frame times (frame_ms_frames, gpu_ms_frames): absent (or null), or an
// array of finite, non-negative milliseconds, not copied; errors name the entry.
const nlohmann::json* optFrameTimes(const nlohmann::json& object, const char* key, const std::string& path);

// The sample's extras, with "roofline" added where its passes carry one
// (docs/result-schema.md, "extras.roofline").
nlohmann::json extrasWithRoofline(nlohmann::json extras, const nlohmann::json& sample, const nlohmann::json& ceilings);

// A counter's fields, read in place (views into the result).
struct CounterFields {
  std::string_view name, access, source;
  std::optional<std::string_view> kind, format;
  double count = 0, bytes = 0;
  std::optional<double> footprint;  // absent (or null) where the line's footprint was not measured
  const nlohmann::json* spread = nullptr;     // absent (or null) where not measured; else an object
};

// The counter at `index` of a pass's "resources" (the pass at `passPath`);
// IngestError naming the first field that is off.
CounterFields counterFields(const nlohmann::json& counter, const std::string& passPath, size_t index);
// Only its bytes and footprint (the rest left empty), read and checked as
// counterFields reads them; errors as counterFields names them.
CounterFields counterBytes(const nlohmann::json& counter, const std::string& passPath, size_t index);

// A sweep result's frame (docs/result-schema.md, "Sweep results"): what the
// sweeps list and the dashboard's charts rely on, whatever the sweep.
// Throws IngestError naming the first bad field.
void checkSweep(const nlohmann::json& result);

// The result's "device" as a devices row: the stored one, or inserted (or
// updated) now; inside the caller's transaction.
int64_t insertDevice(Connection* db, const nlohmann::json& result);

// A capture's runs for a job, replacing earlier ones; inside the caller's
// transaction (ingest_capture.cpp). The number of runs stored.
int64_t storeCapture(Connection* db, int64_t jobId, const nlohmann::json& result,
                     const std::map<std::string, std::vector<uint8_t>>& screenshots,
                     const std::optional<std::string>& host);

}  // namespace tally::store::detail
