// GET /api/crossover: over the runs of one capture, each variant's bytes per
// frame or frame time fitted against the pixel count (y = a + b * pixels,
// analysis/crossover) and, for every pair of variants on the same scene and
// device, where their lines cross. docs/api.md describes the answer and
// docs/measurement.md ("Crossover") the model.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "store/store.hpp"

namespace tally::reports {

// The runs considered per capture (at most), and the metrics that can be fitted.
inline constexpr int kCrossoverMaxRuns = 2000;
bool isCrossoverMetric(const std::string& metric);  // "bytes" or "frame_ms"

// filter: the capture (jobId) and optionally scene and device.
Result<nlohmann::json> crossoverModels(store::Store& store, const store::RunFilter& filter, const std::string& metric);

}  // namespace tally::reports
