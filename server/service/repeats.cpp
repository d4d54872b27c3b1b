#include "service/repeats.hpp"

#include <algorithm>
#include <map>

#include "capture/repeats.hpp"

namespace tally::service {
namespace {

using nlohmann::json;

double iqrOf(const json& spread) {
  if (!spread.is_object()) return 0;
  if (spread.contains("iqr") && spread["iqr"].is_number()) return spread["iqr"].get<double>();
  return spread.value("q3", 0.0) - spread.value("q1", 0.0);
}

// The run's configuration and its samples, as repeatRunsFromResult reads a result.
Result<capture::RepeatRun> load(store::Store& store, const store::RunRow& r) {
  capture::RepeatRun run;
  run.id = std::to_string(r.id);
  run.renderer = r.renderer;
  run.scene = r.scene;
  run.sceneParams = r.sceneParams.dump();
  run.device = std::to_string(r.deviceId);
  run.counting = r.counting;
  run.width = r.width;
  run.height = r.height;
  run.lights = r.lights;
  auto samples = store.listSamples(r.id);
  if (!samples) return makeError(samples.error());
  for (const auto& row : *samples) {
    auto sample = store.getSample(row.id);
    if (!sample) return makeError(sample.error());
    if (!*sample) continue;
    capture::RepeatSample s;
    json camera = row.camera.is_object() ? row.camera : json::object();
    camera.erase("index");
    camera.erase("label");
    s.camera = camera.dump();
    s.frames = row.frames.value_or(0);
    s.frameMs = row.frameMs;
    s.frameMsIqr = iqrOf(row.frameMsSpread);
    s.bytes = row.bytes;
    for (const auto& pass : (*sample)->passes) {
      for (const auto& c : pass.counters) {
        s.counts[pass.name + "/" + c.resource + " " + c.access] += c.count;
        if (c.count > 0) s.bytesIqr += iqrOf(c.countSpread) * c.bytes / c.count;
      }
    }
    run.samples.push_back(std::move(s));
  }
  return run;
}

}  // namespace

Result<json> repeatGroups(store::Store& store, const store::RunFilter& filter) {
  std::vector<store::RunRow> rows;
  store::Page page{1000, ""};
  bool complete = false;
  for (int pages = 0; pages < kRepeatsMaxRuns / 1000; ++pages) {
    auto got = store.listRuns(filter, page);
    if (!got) return makeError(got.error());
    rows.insert(rows.end(), got->runs.begin(), got->runs.end());
    if (got->nextCursor.empty()) {
      complete = true;
      break;
    }
    page.cursor = got->nextCursor;
  }
  std::reverse(rows.begin(), rows.end());  // oldest first

  // Samples only for runs that share their cheap keys with another run.
  std::map<std::string, int> seen;
  auto cheapKey = [](const store::RunRow& r) {
    return json{r.renderer, r.scene, r.sceneParams, r.width, r.height, r.deviceId, r.counting, r.lights, r.sampleCount}
        .dump();
  };
  for (const auto& r : rows) ++seen[cheapKey(r)];
  std::vector<capture::RepeatRun> runs;
  std::map<std::string, const store::RunRow*> rowsById;
  for (const auto& r : rows) {
    if (seen[cheapKey(r)] < 2) continue;
    auto run = load(store, r);
    if (!run) return makeError(run.error());
    rowsById[run->id] = &r;
    runs.push_back(std::move(run).value());
  }

  json groups = json::array();
  for (const auto& g : capture::repeatGroups(runs)) {
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
                      {"frame_ms", capture::toJson(g.frameMs)},
                      {"bytes", capture::toJson(g.bytes)},
                      {"counts", capture::toJson(g.counts)}});
  }
  return json{{"groups", std::move(groups)}, {"band_iqrs", capture::kRepeatBandIqrs}, {"truncated", !complete}};
}

}  // namespace tally::service
