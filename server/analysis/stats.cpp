#include "analysis/stats.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace tally::analysis {
namespace {
double percentile(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return 0;
  double at = p * double(sorted.size() - 1);
  size_t lo = static_cast<size_t>(at);
  size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (sorted[hi] - sorted[lo]) * (at - double(lo));
}
}  // namespace

Spread spreadOf(std::vector<double> values) {
  Spread s;
  s.n = values.size();
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  s.min = values.front();
  s.max = values.back();
  s.median = percentile(values, 0.5);
  s.q1 = percentile(values, 0.25);
  s.q3 = percentile(values, 0.75);
  s.mean = std::accumulate(values.begin(), values.end(), 0.0) / double(values.size());
  return s;
}

nlohmann::json toJson(const Spread& s) {
  return {{"median", s.median}, {"q1", s.q1}, {"q3", s.q3}, {"iqr", s.iqr()},
          {"min", s.min},       {"max", s.max}, {"mean", s.mean}, {"n", s.n}};
}

double iqrOf(const nlohmann::json& spread) {
  if (!spread.is_object()) return 0;
  if (spread.contains("iqr") && spread["iqr"].is_number()) return spread["iqr"].get<double>();
  return spread.value("q3", 0.0) - spread.value("q1", 0.0);
}

}  // namespace tally::analysis
