// Repeated captures: runs of one identical configuration, and whether they
// agree within the noise each run states for itself. Works on plain per-sample
// figures so that `tallyd repeats` (result files) and GET /api/repeats (the
// store) share it. docs/measurement.md ("Repeatability") defines the band.
#pragma once

#include <map>
#include <optional>
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
  std::vector<double> frameTimes;  // every frame's time (ms); empty where not stored (older runs)
  double bytes = 0;        // all counters, per frame
  double bytesIqr = 0;     // sum over counters of each counter's IQR over the frames, in bytes
  std::map<std::string, double> counts;  // "pass/resource access" -> count per frame
};

struct RepeatRun : RunConfig {
  std::vector<RepeatSample> samples;
};

// A run's frame time, the one statistic every view shows (frame_ms_median,
// reports/frame_time.hpp): the median of every frame of every sample pooled,
// with its 95% interval (analysis::medianInterval). Where a sample has no
// per-frame times, the median of the samples' medians without an interval,
// as reports::runFrameTime does.
struct RunFrameMs {
  double median = 0;
  std::optional<double> lower, upper;  // absent below 8 frames, or without per-frame times
  size_t frames = 0;                   // frames pooled; 0 when source is "samples"
  std::string source = "none";         // "frames", "samples" or "none" (no sample)
};
RunFrameMs runFrameMs(const RepeatRun& run);

// What a figure's per-run values are: the run statistic they repeat.
inline constexpr const char* kFrameMsStatistic = "frame_ms_median";  // RunFrameMs, as /api/runs
inline constexpr const char* kBytesStatistic =
    "mean_bytes";  // the mean over samples of their bytes per frame, as /api/runs

// Runs are repeats of each other when these keys are equal: renderer, scene
// and its parameters, resolution, device, counting mode, lights, and the same
// cameras in order, each with the same frame count.
std::string configurationKey(const RepeatRun& run);

// One quantity (frame time or total bytes) over the runs of a group.
struct RepeatFigure {
  std::string statistic;       // kFrameMsStatistic or kBytesStatistic
  std::vector<double> perRun;  // each run's value of the statistic
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
  RepeatFigure frameMs, bytes;         // frameMs.perRun: each run's frameMsOfRuns median
  std::vector<RunFrameMs> frameMsOfRuns;  // in the order of runs
  CountAgreement counts;
};

// perRun: each run's value; iqrsPerRun: each run's samples' IQRs across frames,
// pooled into the within-run noise.
RepeatFigure repeatFigure(std::vector<double> perRun, const std::vector<std::vector<double>>& iqrsPerRun);
// perRun from each run's median over its samples' values.
RepeatFigure repeatFigure(const std::vector<std::vector<double>>& valuesPerRun,
                          const std::vector<std::vector<double>>& iqrsPerRun);
// The run's bytes per frame as every view shows them: the mean over its samples.
double runMeanBytes(const RepeatRun& run);
CountAgreement compareCounts(const std::vector<const RepeatRun*>& runs);

// Every group of two or more runs with one configuration, ordered by their
// first run in `runs`. A run without samples is never a repeat.
std::vector<RepeatGroup> repeatGroups(const std::vector<RepeatRun>& runs);

// A capture result's runs (docs/result-schema.md); ids are "<name>#<position>".
Result<std::vector<RepeatRun>> repeatRunsFromResult(const nlohmann::json& result, const std::string& name);

// The figures as JSON (the API's and `tallyd repeats --json`'s fields).
nlohmann::json toJson(const RepeatFigure& figure);
// The group's frame_ms: toJson(frameMs) with each run's interval and source
// beside per_run (per_run_lower, per_run_upper: null where absent; per_run_source).
nlohmann::json frameMsJson(const RepeatGroup& group);
nlohmann::json toJson(const CountAgreement& counts);

}  // namespace tally::analysis
