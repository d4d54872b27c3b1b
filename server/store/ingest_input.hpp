// What the ingest's files share to read a result (ingest.cpp, ingest_capture.cpp, sweep_frame.cpp):
// bad input throws IngestError naming the JSON path, and the ingest's
// transaction then rolls back.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/json_fields.hpp"
#include "store/db.hpp"
#include "store/frame_time.hpp"

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

// The columns of an {"against", "psnr", "identical", "max_abs", "mean_abs"}
// object (image_error, variant_error); all empty when the sample has no such
// key. "against" defaults to `defaultAgainst` where given, else is required.
struct ImageErrorColumns {
  std::optional<std::string> against;
  std::optional<int64_t> identical;
  std::optional<double> psnr, maxAbs, meanAbs;
};
ImageErrorColumns imageErrorColumns(const nlohmann::json& sample, const char* key, const std::string& at,
                                    const std::optional<std::string>& defaultAgainst);

// A sample's sums over its passes' lines, written on its row: all the
// lines' bytes; the footprint of the lines that have one and those lines'
// requested bytes (absent when none has).
struct CounterSums {
  double bytes = 0;
  std::optional<double> footprint, footprintRequested;
};
CounterSums counterSums(const nlohmann::json& sample, const std::string& path);

// A sample's values that both its row and its run's row (migration 0013)
// hold, read and checked once, before the run's row is written: the camera's
// index in the run (refused when an earlier sample has it), frame_ms and its
// per-frame times as the readers get them back (an empty array is none), the
// counted frame, the image error against the reference and the lines' sums.
struct SampleValues {
  int64_t cameraIndex = 0;
  SampleFrameTimes times;
  std::optional<double> frameMsInstrumented, overheadRatio;
  ImageErrorColumns image;
  CounterSums sums;
};
// The run's samples' values, in the result's order (the run at `path`).
std::vector<SampleValues> readSampleValues(const nlohmann::json& run, const std::string& path);

// A run's summary columns (migration 0013) over its samples' values.
struct RunSummaryColumns {
  int64_t sampleCount = 0, imageCompared = 0, imageIdentical = 0;
  std::optional<double> meanFrameMs, meanBytes, meanFrameMsInstrumented, meanOverheadRatio, meanPsnr, minPsnr,
      meanFootprintBytes, meanFootprintRequestedBytes;
};
// COUNT, AVG and MIN as both engines computed them in the statement of
// migration 0013 (a plain sum in the samples' camera order, divided by the
// count of values); a sum that leaves the doubles throws IngestError naming
// the column, as PostgreSQL's AVG refused it. `path`: the run.
RunSummaryColumns summarizeRun(std::span<const SampleValues> samples, const std::string& path);

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
