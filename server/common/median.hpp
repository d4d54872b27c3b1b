// The median of values and its distribution-free 95% interval, in common/
// because both the store (a run's frame time, written at ingest:
// store/frame_time.hpp) and analysis (the repeats, analysis/repeats.hpp; and
// through analysis/stats.hpp) compute it, and the store includes nothing else.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

namespace tally {

// Order statistics k and n + 1 - k, k = floor(n/2 - 0.98 sqrt(n)) from the
// normal approximation to Binomial(n, 1/2) (P(X < k) <= 2.5%). A run's frame
// time (reports/frame_time.hpp) and the repeats' per-run figure
// (analysis/repeats.hpp) are this over the run's frames.
struct MedianInterval {
  std::optional<double> median;        // absent: no values
  std::optional<double> lower, upper;  // absent when k < 1 (fewer than 8 values)
  size_t n = 0;
};
MedianInterval medianInterval(std::vector<double> values);

}  // namespace tally
