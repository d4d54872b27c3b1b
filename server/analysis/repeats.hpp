// Repeated captures: runs of one identical configuration, and whether they
// agree within the noise each run states for itself. Works on plain per-sample
// figures so that `tallyd repeats` (result files) and GET /api/repeats (the
// store) share it. docs/measurement.md ("Repeatability") defines the band.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/run_config.hpp"
#include "analysis/stats.hpp"
#include "common/result.hpp"

namespace tally::analysis {

// A run's value may lie at most this many within-run IQRs from the
// across-run median (docs/measurement.md, "Repeatability", says why 1).
inline constexpr double kRepeatBandIqrs = 1.0;

// One sample (camera) of one run.
struct RepeatSample {
  std::string camera;  // the camera as compact JSON (without index and label)
  int frames = 0;      // frames timed and counted
  double frameMs = 0;      // uninstrumented frame time, median over the frames
  double frameMsIqr = 0;   // its IQR over the frames
  double bytes = 0;        // all counters, per frame
  double bytesIqr = 0;     // sum over counters of each counter's IQR over the frames, in bytes
  std::map<std::string, double> counts;  // "pass/resource access" -> count per frame
};

struct RepeatRun : RunConfig {
  std::vector<RepeatSample> samples;
};

// Runs are repeats of each other when these keys are equal: renderer, scene
// and its parameters, resolution, device, counting mode, lights, and the same
// cameras in order, each with the same frame count.
std::string configurationKey(const RepeatRun& run);

// One quantity (frame time or total bytes) over the runs of a group.
struct RepeatFigure {
  std::vector<double> perRun;  // each run's median over its samples
  Spread across;               // spread of perRun (median, quartiles, min, max)
  double noise = 0;            // within-run noise: median over the group's samples of their IQR across frames
  double low = 0, high = 0;    // the band: across.median -/+ kRepeatBandIqrs x noise
  bool agrees = false;         // every perRun value lies in [low, high]
};

struct CountAgreement {
  bool identical = true;   // every counter of every sample equal in every run (and the same counters)
  size_t counters = 0;     // (sample, counter) pairs compared, per run
  std::string firstDifference;  // "camera 0: pass/resource access: 12 != 13"; empty when identical
};

struct RepeatGroup {
  std::vector<const RepeatRun*> runs;  // in the order given
  RepeatFigure frameMs, bytes;
  CountAgreement counts;
};

RepeatFigure repeatFigure(const std::vector<std::vector<double>>& valuesPerRun,
                          const std::vector<std::vector<double>>& iqrsPerRun);
CountAgreement compareCounts(const std::vector<const RepeatRun*>& runs);

// Every group of two or more runs with one configuration, ordered by their
// first run in `runs`. A run without samples is never a repeat.
std::vector<RepeatGroup> repeatGroups(const std::vector<RepeatRun>& runs);

// A capture result's runs (docs/result-schema.md); ids are "<name>#<position>".
Result<std::vector<RepeatRun>> repeatRunsFromResult(const nlohmann::json& result, const std::string& name);

// The figures as JSON (the API's and `tallyd repeats --json`'s fields).
nlohmann::json toJson(const RepeatFigure& figure);
nlohmann::json toJson(const CountAgreement& counts);

}  // namespace tally::analysis
