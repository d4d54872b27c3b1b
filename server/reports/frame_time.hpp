// A run's frame time, one statistic for every view that shows one (the runs
// list, a run's tiles, the trend, alerts and compare): the median of every
// per-frame time of the run pooled over its cameras, with a distribution-free
// 95% interval. docs/statistics.md, "One frame time per run", says why the
// median and what the older mean_frame_ms is.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "store/store.hpp"

namespace tally::reports {

struct RunFrameTime {
  std::optional<double> median;        // absent: the run has no sample
  std::optional<double> lower, upper;  // the median's 95% interval; absent below 8 frames or without per-frame times
  size_t frames = 0;                   // per-frame times the median is over; 0 when source is "samples"
  // "frames": every per-frame time of every sample; "samples": the median of
  // the samples' own medians, where a sample has no per-frame times stored
  // (runs ingested before they were kept); "none": no sample.
  std::string source = "none";
};

// From each sample's frame_ms and per-frame times (store::SampleFrameTimes).
RunFrameTime runFrameTime(const std::vector<store::SampleFrameTimes>& samples);
Result<RunFrameTime> runFrameTime(store::Store& store, int64_t runId);
// Each of many runs' (a listing's page) from one statement, by run id; every
// id has an entry ("none" where the run has no sample).
Result<std::map<int64_t, RunFrameTime>> runFrameTimes(store::Store& store, std::span<const int64_t> runIds);

// The median and its interval of sorted times: order statistics k and
// n + 1 - k, k = floor(n/2 - 0.98 sqrt(n)) from the normal approximation to
// Binomial(n, 1/2) (P(X < k) <= 2.5%); no interval when k < 1.
RunFrameTime medianOfFrames(std::vector<double> times);

// {median, lower, upper, frames, source}, as GET /api/trend serves a run's
// frame_ms.
nlohmann::json toJson(const RunFrameTime& t);

// Adds frame_ms_median (a number or null) and frame_ms_median_source to a
// run's JSON row (service::runRowJson).
void addFrameMedian(const RunFrameTime& t, nlohmann::json& row);

}  // namespace tally::reports
