#include "common/median.hpp"

#include <algorithm>
#include <cmath>

namespace tally {

MedianInterval medianInterval(std::vector<double> values) {
  MedianInterval out;
  if (values.empty()) return out;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  out.median = n % 2 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
  out.n = n;
  const double k = std::floor(n / 2.0 - 0.98 * std::sqrt(static_cast<double>(n)));
  if (k >= 1) {
    out.lower = values[static_cast<size_t>(k) - 1];
    out.upper = values[n - static_cast<size_t>(k)];
  }
  return out;
}

}  // namespace tally
