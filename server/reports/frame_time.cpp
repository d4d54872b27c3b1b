#include "reports/frame_time.hpp"

#include <algorithm>
#include <cmath>

namespace tally::reports {

using nlohmann::json;

RunFrameTime medianOfFrames(std::vector<double> times) {
  RunFrameTime out;
  if (times.empty()) return out;
  std::sort(times.begin(), times.end());
  const size_t n = times.size();
  out.median = n % 2 ? times[n / 2] : (times[n / 2 - 1] + times[n / 2]) / 2;
  out.frames = n;
  out.source = "frames";
  const double k = std::floor(n / 2.0 - 0.98 * std::sqrt(static_cast<double>(n)));
  if (k >= 1) {
    out.lower = times[static_cast<size_t>(k) - 1];
    out.upper = times[n - static_cast<size_t>(k)];
  }
  return out;
}

RunFrameTime runFrameTime(const std::vector<store::SampleFrameTimes>& samples) {
  std::vector<double> times, medians;
  bool everyFrame = !samples.empty();
  for (const auto& s : samples) {
    medians.push_back(s.frameMs);
    everyFrame = everyFrame && !s.frames.empty();
    times.insert(times.end(), s.frames.begin(), s.frames.end());
  }
  if (everyFrame) return medianOfFrames(std::move(times));
  RunFrameTime out;
  if (medians.empty()) return out;
  // A sample without its frames: the median of the samples' medians, the
  // nearest statistic to the pooled median, without an interval.
  out = medianOfFrames(std::move(medians));
  out.lower = out.upper = std::nullopt;
  out.frames = 0;
  out.source = "samples";
  return out;
}

Result<RunFrameTime> runFrameTime(store::Store& store, int64_t runId) {
  auto samples = store.runs().sampleFrameTimes(runId);
  if (!samples) return makeError(samples.error());
  return runFrameTime(*samples);
}

json toJson(const RunFrameTime& t) {
  auto opt = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  return {{"median", opt(t.median)},
          {"lower", opt(t.lower)},
          {"upper", opt(t.upper)},
          {"frames", t.frames},
          {"source", t.source}};
}

void addFrameMedian(const RunFrameTime& t, json& row) {
  row["frame_ms_median"] = t.median ? json(*t.median) : json(nullptr);
  row["frame_ms_median_source"] = t.source;
}

}  // namespace tally::reports
