// Capture results for filling a benchmark database. The shapes come from a
// real capture result (each renderer's resource list, passes and per-resource
// counters, with their spreads, cameras and image errors); devices, scenes,
// resolutions and values are varied synthetically. They are stored through
// Store::ingestCapture, the path the daemon's worker takes after a capture.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "store/store.hpp"

namespace tally::bench {

struct CaptureTemplate {
  nlohmann::json device;                       // the real capture's device object
  std::map<std::string, nlohmann::json> runs;  // one real run (with its samples) per renderer
};

// Reads a capture result (JSON, gzip-compressed or not) and keeps the first
// run of each renderer. Fails when one of `renderers` has no run there, so a
// new renderer asks for a new template instead of borrowing another's shape.
Result<CaptureTemplate> loadTemplate(const std::string& path, const std::vector<std::string>& renderers);

struct SyntheticCapture {
  nlohmann::json spec;    // what the job is created with
  nlohmann::json result;  // docs/result-schema.md
  std::map<std::string, std::vector<uint8_t>> screenshots;
  int64_t samples = 0;
};

// Capture number `index` of a fill: one device, every renderer x 2 scenes x 2
// resolutions x 10 cameras (200 samples, a typical study), cut short after
// `maxSamples`. Deterministic in `index`.
SyntheticCapture makeCapture(const CaptureTemplate& source, const std::vector<std::string>& renderers,
                             int index, int64_t maxSamples);

struct FillStats {
  int captures = 0;
  int64_t samples = 0;
  double seconds = 0;        // the whole fill
  double ingestSeconds = 0;  // inside Store::ingestCapture
  // The CPU time of those calls: this process's (the ingest's threads), and (PostgreSQL on this
  // machine, where /proc shows its backend) the server backend's; -1 when
  // not known.
  double ingestClientCpuSeconds = 0, ingestServerCpuSeconds = -1;
  // After the last ingest: waiting for the statistics the ingests asked for
  // (PostgreSQL's ANALYZE, which runs beside them; Runs::waitForStatistics).
  double statisticsWaitSeconds = 0;
};

// Creates, claims, ingests and finishes one job per capture until `samples`
// samples are stored, as the worker does. `progress` gets the samples stored so far.
Result<FillStats> fillDatabase(store::Store& writer, const CaptureTemplate& source,
                               const std::vector<std::string>& renderers, int64_t samples,
                               const std::function<void(int64_t)>& progress);

}  // namespace tally::bench
