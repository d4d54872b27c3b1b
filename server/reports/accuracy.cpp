#include "reports/accuracy.hpp"

#include <algorithm>
#include <map>
#include <set>

#include "analysis/accuracy.hpp"
#include "reports/run_rows.hpp"

namespace tally::reports {
namespace {

using nlohmann::json;

analysis::RunCounts metadata(const store::RunRow& r) {
  analysis::RunCounts c;
  static_cast<analysis::RunConfig&>(c) = runConfigOf(r);
  c.group = std::to_string(r.jobId);
  return c;
}

// The run's samples with their per-line bytes, as runCountsFromResult reads them.
Result<bool> loadSamples(store::Store& store, int64_t runId, analysis::RunCounts& run) {
  auto samples = store.runs().samples(runId);
  if (!samples) return makeError(samples.error());
  for (const auto& row : *samples) {
    auto sample = store.runs().sample(row.id);
    if (!sample) return makeError(sample.error());
    if (!*sample) continue;
    analysis::SampleCounts counts;
    counts.camera = analysis::cameraKey(row.camera);
    counts.frameMs = row.frameMs;
    counts.frameMsInstrumented = row.frameMsInstrumented.value_or(0.0);
    for (const auto& pass : (*sample)->passes) {
      for (const auto& c : pass.counters) counts.bytes[lineKey(pass.name, c)] += c.bytes;
    }
    run.samples.push_back(std::move(counts));
  }
  return true;
}

}  // namespace

Result<json> accuracyRows(store::Store& store, const store::RunFilter& filter) {
  bool complete = false;
  auto selected = selectRuns(store, filter, kAccuracyMaxRuns, complete);
  if (!selected) return makeError(selected.error());

  // Candidates for references: every exact run of the same renderer and
  // scene (any capture, any time), whatever else the filter says.
  std::vector<analysis::RunCounts> pool;
  std::map<int64_t, size_t> index;  // run id -> position in pool
  std::vector<int64_t> rowIds;
  std::set<std::string> queried;  // renderer, scene, resolution, device already looked up
  for (const auto& r : *selected) {
    if (r.counting == "exact") continue;
    rowIds.push_back(r.id);
    if (!index.count(r.id)) {
      index[r.id] = pool.size();
      pool.push_back(metadata(r));
    }
    std::string key = r.variant + "\x1f" + r.scene + "\x1f" + std::to_string(r.width) + "x" +
                      std::to_string(r.height) + "\x1f" + std::to_string(r.deviceId);
    if (!queried.insert(key).second) continue;
    store::RunFilter same;
    same.renderer = r.renderer;
    same.variant = r.variant;  // a variant's exact reference is the exact run of the same variant
    same.scene = r.scene;
    same.width = r.width;
    same.height = r.height;
    same.deviceId = r.deviceId;
    bool all = false;
    auto exact = selectRuns(store, same, kAccuracyMaxRuns, all);
    if (!exact) return makeError(exact.error());
    for (const auto& e : *exact) {
      if (e.counting == "exact" && !index.count(e.id)) {
        index[e.id] = pool.size();
        pool.push_back(metadata(e));
      }
    }
  }
  // Samples for the runs compared only: the pool's exact runs that could match
  // (same parameters and sample count) and the rows themselves.
  std::vector<bool> needed(pool.size(), false);
  for (int64_t id : rowIds) {
    const auto& run = pool[index[id]];
    needed[index[id]] = true;
    for (size_t i = 0; i < pool.size(); ++i) {
      const auto& e = pool[i];
      if (e.counting == "exact" && e.renderer == run.renderer && e.options == run.options && e.scene == run.scene &&
          e.sceneParams == run.sceneParams && e.lights == run.lights) {
        needed[i] = true;
      }
    }
  }
  for (size_t i = 0; i < pool.size(); ++i) {
    if (!needed[i]) continue;
    auto ok = loadSamples(store, std::stoll(pool[i].id), pool[i]);
    if (!ok) return makeError(ok.error());
  }
  // findReference takes the last match as the newest: order by id.
  std::vector<analysis::RunCounts> sorted = pool;
  std::sort(sorted.begin(), sorted.end(),
            [](const auto& a, const auto& b) { return std::stoll(a.id) < std::stoll(b.id); });

  std::map<int64_t, const store::RunRow*> rowsById;
  for (const auto& r : *selected) rowsById[r.id] = &r;
  json rows = json::array();
  for (int64_t id : rowIds) {
    const auto& run = pool[index[id]];
    const store::RunRow& r = *rowsById[id];
    json j = {{"run", r.id},
              {"capture", r.jobId},
              {"renderer", r.renderer},
              {"options", r.options},
              {"variant", r.variant},
              {"scene", r.scene},
              {"width", r.width},
              {"height", r.height},
              {"device", r.deviceName},
              {"lights", r.lights},
              {"counting", r.counting},
              // Footprint counting costs time of its own: its runs are points of their own.
              {"footprint_block_bytes", r.footprintBlockBytes ? json(*r.footprintBlockBytes) : json(nullptr)},
              {"created_at", r.createdAt},
              {"sample_count", static_cast<int64_t>(run.samples.size())}};
    std::string why;
    auto ref = analysis::findReference(run, sorted, &why);
    std::optional<analysis::RunAccuracy> accuracy;
    if (ref) {
      auto a = analysis::compareToExact(run, sorted[*ref]);
      if (a) {
        accuracy = std::move(a).value();
      } else {
        why = a.error();
      }
    }
    if (!accuracy) {
      j["reference"] = nullptr;
      j["reason"] = why;
      for (const char* k : {"overhead_ratio", "reference_overhead_ratio", "total_error", "l1_error", "worst_error",
                            "worst_resource", "worst_sample"}) {
        j[k] = nullptr;
      }
    } else {
      j["reference"] = std::stoll(sorted[*ref].id);
      j["reason"] = nullptr;
      j["overhead_ratio"] = accuracy->overheadRatio;
      j["reference_overhead_ratio"] = accuracy->referenceOverheadRatio;
      j.update(analysis::toJson(accuracy->errors));
      j["worst_sample"] = static_cast<int64_t>(accuracy->worstSample);
    }
    rows.push_back(std::move(j));
  }
  return json{{"rows", std::move(rows)}, {"truncated", !complete}};
}

}  // namespace tally::reports
