// A run's frame time (reports/frame_time.hpp is its API for every view): the
// median of every per-frame time of the run pooled over its cameras, with a
// distribution-free 95% interval. Here, in the store, because the ingest
// computes it once and writes it on the run's row (migration 0013), with the
// same code the readers use for runs stored before.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace tally::store {

// A sample's frame time (frame_ms: its median over the frames) and its
// per-frame times (empty when not stored).
struct SampleFrameTimes {
  double frameMs = 0;
  std::vector<double> frames;
};

struct RunFrameTime {
  std::optional<double> median;        // absent: the run has no sample
  std::optional<double> lower, upper;  // the median's 95% interval; absent below 8 frames or without per-frame times
  size_t frames = 0;                   // per-frame times the median is over; 0 when source is "samples"
  // "frames": every per-frame time of every sample; "samples": the median of
  // the samples' own medians, where a sample has no per-frame times stored
  // (runs ingested before they were kept); "none": no sample.
  std::string source = "none";
};

// The median and its interval of sorted times: order statistics k and
// n + 1 - k, k = floor(n/2 - 0.98 sqrt(n)) from the normal approximation to
// Binomial(n, 1/2) (P(X < k) <= 2.5%); no interval when k < 1.
RunFrameTime medianOfFrames(std::vector<double> times);

// From each sample's frame_ms and per-frame times.
RunFrameTime runFrameTime(const std::vector<SampleFrameTimes>& samples);

}  // namespace tally::store
