// Spread of repeated measurements: every figure Tally reports comes with it.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

namespace tally::analysis {

struct Spread {
  double median = 0;
  double q1 = 0;  // 25th percentile
  double q3 = 0;  // 75th percentile
  double min = 0;
  double max = 0;
  double mean = 0;
  size_t n = 0;
  double iqr() const { return q3 - q1; }
};

// Percentiles by linear interpolation between order statistics.
Spread spreadOf(std::vector<double> values);
nlohmann::json toJson(const Spread& s);

// The median of values and its distribution-free 95% interval: order
// statistics k and n + 1 - k, k = floor(n/2 - 0.98 sqrt(n)) from the normal
// approximation to Binomial(n, 1/2) (P(X < k) <= 2.5%). A run's frame time
// (reports/frame_time.hpp) and the repeats' per-run figure (analysis/repeats.hpp)
// are this over the run's frames.
struct MedianInterval {
  std::optional<double> median;        // absent: no values
  std::optional<double> lower, upper;  // absent when k < 1 (fewer than 8 values)
  size_t n = 0;
};
MedianInterval medianInterval(std::vector<double> values);

// The IQR of a stored spread (toJson's object): 0 when there is none.
double iqrOf(const nlohmann::json& spread);

}  // namespace tally::analysis
