#include "reports/frame_time.hpp"

#include "analysis/stats.hpp"

namespace tally::reports {

using nlohmann::json;

RunFrameTime medianOfFrames(std::vector<double> times) {
  RunFrameTime out;
  const analysis::MedianInterval m = analysis::medianInterval(std::move(times));
  if (!m.median) return out;
  out.median = m.median;
  out.lower = m.lower;
  out.upper = m.upper;
  out.frames = m.n;
  out.source = "frames";
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

Result<std::map<int64_t, RunFrameTime>> runFrameTimes(store::Store& store, std::span<const int64_t> runIds) {
  auto samples = store.runs().sampleFrameTimes(runIds);
  if (!samples) return makeError(samples.error());
  std::map<int64_t, RunFrameTime> out;
  for (int64_t id : runIds) {
    auto it = samples->find(id);
    out[id] = it == samples->end() ? RunFrameTime{} : runFrameTime(it->second);
  }
  return out;
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
