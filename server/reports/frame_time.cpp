#include "reports/frame_time.hpp"

namespace tally::reports {

using nlohmann::json;

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

Result<RunFrameTime> frameTimeOf(store::Store& store, const store::RunRow& run) {
  if (run.frameTime) return *run.frameTime;
  return runFrameTime(store, run.id);
}

Result<std::map<int64_t, RunFrameTime>> frameTimesOf(store::Store& store, std::span<const store::RunRow> runs) {
  std::map<int64_t, RunFrameTime> out;
  std::vector<int64_t> missing;
  for (const auto& r : runs) {
    if (r.frameTime) {
      out[r.id] = *r.frameTime;
    } else {
      missing.push_back(r.id);
    }
  }
  if (missing.empty()) return out;
  auto computed = runFrameTimes(store, missing);
  if (!computed) return makeError(computed.error());
  out.merge(*computed);
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

}  // namespace tally::reports
