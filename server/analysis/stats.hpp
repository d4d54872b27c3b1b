// Spread of repeated measurements: every figure Tally reports comes with it.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/median.hpp"

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

// The median of values and its distribution-free 95% interval
// (common/median.hpp, shared with the store).
using tally::MedianInterval;
using tally::medianInterval;

// The IQR of a stored spread (toJson's object): 0 when there is none.
double iqrOf(const nlohmann::json& spread);

}  // namespace tally::analysis
