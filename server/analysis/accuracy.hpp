// Counting accuracy: a run counted in a cheaper mode (subgroup, sampled:N)
// against the same run counted exactly. Works on plain per-resource counts so
// that `tallyd accuracy` (a result file) and the server (the store) share it.
// See docs/accuracy.md for the method.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/run_config.hpp"
#include "common/result.hpp"

namespace tally::analysis {

// One sample (camera) of one run: bytes per frame for every line, where a
// line is "pass/resource access" (gbuffer/gbuffer.normal write).
struct SampleCounts {
  std::string camera;  // the camera as compact JSON: samples match when equal
  double frameMs = 0;              // uninstrumented frame, median
  double frameMsInstrumented = 0;  // counted frame, median
  std::map<std::string, double> bytes;
};

// What a run is, for finding its exact reference, and its samples.
struct RunCounts : RunConfig {
  std::string group;  // the capture (job) it came from; a reference from the same one is preferred
  std::vector<SampleCounts> samples;
};

struct ErrorFigures {
  // |sum b - sum b_exact| / sum b_exact: what a total-bytes comparison sees.
  double total = 0;
  // sum |b - b_exact| / sum b_exact over lines: errors cannot cancel.
  double l1 = 0;
  // max over lines of |b - b_exact| / b_exact (a line the exact run does not
  // have, or has at 0 bytes, counts 1 when the other run has bytes there).
  double worst = 0;
  std::string worstLine;  // empty when every line agrees
};

struct SampleAccuracy {
  size_t index = 0;  // position in the run's samples
  ErrorFigures errors;
  double overheadRatio = 0;           // the run's: instrumented / uninstrumented frame time
  double referenceOverheadRatio = 0;  // the exact run's
};

struct RunAccuracy {
  ErrorFigures errors;  // over every (sample, line): sums over samples; worst over samples and lines
  size_t worstSample = 0;
  double overheadRatio = 0;           // median over samples
  double referenceOverheadRatio = 0;  // median over the exact run's samples
  std::vector<SampleAccuracy> samples;
};

// Same renderer, scene and parameters, resolution, device, lights and
// cameras (same count, equal in order): the runs measured the same frames.
bool sameFrames(const RunCounts& a, const RunCounts& b);

// The errors of `run` against `exact`. Fails when the runs do not measure the
// same frames, or the exact run has no bytes at all.
Result<RunAccuracy> compareToExact(const RunCounts& run, const RunCounts& exact);

// The exact run `run` is measured against: one with sameFrames(), from the
// same group when there is one, else the last in `runs` (callers list them
// oldest first, so this is the newest). Empty with `why` set when none.
std::optional<size_t> findReference(const RunCounts& run, const std::vector<RunCounts>& runs, std::string* why);

// A capture result's runs (docs/result-schema.md), in result order; ids are
// the positions. Device and group are the same for all of them.
Result<std::vector<RunCounts>> runCountsFromResult(const nlohmann::json& result);

// One row per non-exact run: its figures against its reference, or a reason.
struct AccuracyRow {
  const RunCounts* run = nullptr;
  const RunCounts* reference = nullptr;  // null: see `reason`
  std::optional<RunAccuracy> accuracy;
  std::string reason;
};
std::vector<AccuracyRow> accuracyRows(const std::vector<RunCounts>& runs);

// Figures as JSON (the API's and `tallyd accuracy --json`'s fields).
nlohmann::json toJson(const ErrorFigures& errors);

}  // namespace tally::analysis
