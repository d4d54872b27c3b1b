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

// The type and the pure computation live in the store (store/frame_time.hpp),
// which writes each run's frame time at ingest (migration 0013).
using store::RunFrameTime;
// From each sample's frame_ms and per-frame times (store::SampleFrameTimes).
using store::runFrameTime;
// The median and its interval of sorted times: order statistics k and
// n + 1 - k, k = floor(n/2 - 0.98 sqrt(n)) from the normal approximation to
// Binomial(n, 1/2) (P(X < k) <= 2.5%); no interval when k < 1.
using store::medianOfFrames;

// Computed from the run's samples (one statement).
Result<RunFrameTime> runFrameTime(store::Store& store, int64_t runId);
// Each of many runs' (a listing's page) from one statement, by run id; every
// id has an entry ("none" where the run has no sample).
Result<std::map<int64_t, RunFrameTime>> runFrameTimes(store::Store& store, std::span<const int64_t> runIds);

// The frame time of a run row: the one stored at ingest (0013), or computed
// from its samples for a run stored before.
Result<RunFrameTime> frameTimeOf(store::Store& store, const store::RunRow& run);
// The same for many rows (a listing's page): the stored ones as they are,
// the others from one statement over their samples (none when every row has
// its frame time); every row's id has an entry.
Result<std::map<int64_t, RunFrameTime>> frameTimesOf(store::Store& store, std::span<const store::RunRow> runs);

// {median, lower, upper, frames, source}, as GET /api/trend serves a run's
// frame_ms.
nlohmann::json toJson(const RunFrameTime& t);

}  // namespace tally::reports
