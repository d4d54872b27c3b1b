#include "reports/repeats.hpp"

#include <algorithm>
#include <map>

#include "analysis/repeats.hpp"
#include "analysis/stats.hpp"
#include "reports/run_rows.hpp"

namespace tally::reports {
namespace {

using nlohmann::json;

// The run's configuration and its samples, as repeatRunsFromResult reads a result.
Result<analysis::RepeatRun> load(store::Store& store, const store::RunRow& r) {
  analysis::RepeatRun run;
  static_cast<analysis::RunConfig&>(run) = runConfigOf(r);
  auto samples = store.runs().samples(r.id);
  if (!samples) return makeError(samples.error());
  for (const auto& row : *samples) {
    auto sample = store.runs().sample(row.id);
    if (!sample) return makeError(sample.error());
    if (!*sample) continue;
    analysis::RepeatSample s;
    s.camera = analysis::cameraKey(row.camera);
    s.frames = row.frames.value_or(0);
    s.frameMs = row.frameMs;
    s.frameMsIqr = analysis::iqrOf(row.frameMsSpread);
    s.frameTimes = (*sample)->row.frameMsFrames;
    s.bytes = row.bytes;
    for (const auto& pass : (*sample)->passes) {
      for (const auto& c : pass.counters) {
        s.counts[lineKey(pass.name, c)] += c.count;
        if (c.count > 0) s.bytesIqr += analysis::iqrOf(c.countSpread) * c.bytes / c.count;
      }
    }
    run.samples.push_back(std::move(s));
  }
  return run;
}

}  // namespace

Result<json> repeatGroups(store::Store& store, const store::RunFilter& filter) {
  bool complete = false;
  auto selected = selectRuns(store, filter, kRepeatsMaxRuns, complete);  // oldest first
  if (!selected) return makeError(selected.error());
  const std::vector<store::RunRow>& rows = *selected;

  // Samples only for runs that share their cheap keys with another run.
  std::map<std::string, int> seen;
  auto cheapKey = [](const store::RunRow& r) {
    return json{r.renderer, r.options, r.scene, r.sceneParams, r.width, r.height, r.deviceId, r.counting, r.lights, r.sampleCount}
        .dump();
  };
  for (const auto& r : rows) ++seen[cheapKey(r)];
  std::vector<analysis::RepeatRun> runs;
  std::map<std::string, const store::RunRow*> rowsById;
  for (const auto& r : rows) {
    if (seen[cheapKey(r)] < 2) continue;
    auto run = load(store, r);
    if (!run) return makeError(run.error());
    rowsById[run->id] = &r;
    runs.push_back(std::move(run).value());
  }

  json groups = json::array();
  for (const auto& g : analysis::repeatGroups(runs)) {
    const store::RunRow& first = *rowsById[g.runs.front()->id];
    json ids = json::array(), captures = json::array(), frames = json::array();
    for (const auto* run : g.runs) {
      ids.push_back(std::stoll(run->id));
      captures.push_back(rowsById[run->id]->jobId);
    }
    for (const auto& s : g.runs.front()->samples) frames.push_back(s.frames);
    groups.push_back({{"runs", ids},
                      {"captures", captures},
                      {"renderer", first.renderer},
                      {"options", first.options},
                      {"variant", first.variant},
                      {"scene", first.scene},
                      {"scene_params", first.sceneParams},
                      {"width", first.width},
                      {"height", first.height},
                      {"device_id", first.deviceId},
                      {"device", first.deviceName},
                      {"counting", first.counting},
                      {"lights", first.lights},
                      {"cameras", g.runs.front()->samples.size()},
                      {"frames", frames},
                      {"frame_ms", analysis::frameMsJson(g)},
                      {"bytes", analysis::toJson(g.bytes)},
                      {"counts", analysis::toJson(g.counts)}});
  }
  return json{{"groups", std::move(groups)}, {"band_iqrs", analysis::kRepeatBandIqrs}, {"truncated", !complete}};
}

}  // namespace tally::reports
