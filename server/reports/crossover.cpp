#include "reports/crossover.hpp"

#include <map>
#include <vector>

#include "analysis/crossover.hpp"
#include "reports/frame_time.hpp"
#include "reports/run_rows.hpp"

namespace tally::reports {

using nlohmann::json;

bool isCrossoverMetric(const std::string& metric) { return metric == "bytes" || metric == "frame_ms"; }

namespace {

// One series: the runs of one variant on one scene (with its parameters),
// device, counting mode, light count and footprint block size.
struct Series {
  std::string key, pairKey;  // pairKey: everything but the variant
  const store::RunRow* first = nullptr;
  std::vector<const store::RunRow*> runs;
  std::optional<analysis::LinearFit> fit;
  std::string error;
};

}  // namespace

Result<json> crossoverModels(store::Store& store, const store::RunFilter& filter, const std::string& metric) {
  bool complete = false;
  auto selected = selectRuns(store, filter, kCrossoverMaxRuns, complete);  // oldest first
  if (!selected) return makeError(selected.error());
  const std::vector<store::RunRow>& rows = *selected;

  std::vector<Series> series;
  std::map<std::string, size_t> byKey;
  for (const auto& r : rows) {
    std::string pairKey = json{r.scene, r.sceneParams, r.deviceId, r.counting, r.lights,
                               r.footprintBlockBytes ? json(*r.footprintBlockBytes) : json(nullptr)}
                              .dump();
    std::string variant = r.variant.empty() ? r.renderer : r.variant;
    std::string key = json{variant, pairKey}.dump();
    auto [it, added] = byKey.emplace(key, series.size());
    if (added) series.push_back({key, pairKey, &r, {}, {}, {}});
    series[it->second].runs.push_back(&r);
  }

  json out = json::array();
  for (auto& s : series) {
    std::vector<double> pixels, values;
    std::vector<const store::RunRow*> used;
    for (const auto* r : s.runs) {
      // Frame time as every view shows it: the run's median (reports/frame_time.hpp).
      std::optional<double> v = r->meanBytes;
      if (metric != "bytes") {
        auto t = frameTimeOf(store, *r);
        if (!t) return makeError(t.error());
        v = t->median;
      }
      if (!v) continue;  // a run without samples
      pixels.push_back(double(r->width) * double(r->height));
      values.push_back(*v);
      used.push_back(r);
    }
    auto fit = analysis::fitLinear(pixels, values);
    json fitJson = nullptr;
    if (fit) {
      s.fit = *fit;
      fitJson = analysis::toJson(*fit);
      for (size_t i = 0; i < used.size(); ++i) {
        fitJson["points"][i]["run"] = used[i]->id;
        fitJson["points"][i]["width"] = used[i]->width;
        fitJson["points"][i]["height"] = used[i]->height;
      }
    } else {
      s.error = fit.error();
    }
    json runIds = json::array();
    for (const auto* r : used) runIds.push_back(r->id);
    const store::RunRow& f = *s.first;
    out.push_back({{"variant", f.variant.empty() ? f.renderer : f.variant},
                   {"renderer", f.renderer},
                   {"scene", f.scene},
                   {"scene_params", f.sceneParams},
                   {"device_id", f.deviceId},
                   {"device", f.deviceName},
                   {"counting", f.counting},
                   {"lights", f.lights},
                   {"footprint_block_bytes", f.footprintBlockBytes ? json(*f.footprintBlockBytes) : json(nullptr)},
                   {"runs", runIds},
                   {"fit", fitJson},
                   {"error", s.error.empty() ? json(nullptr) : json(s.error)}});
  }

  json crossings = json::array();
  for (size_t i = 0; i < series.size(); ++i) {
    for (size_t j = i + 1; j < series.size(); ++j) {
      const Series &s1 = series[i], &s2 = series[j];
      if (s1.pairKey != s2.pairKey || !s1.fit || !s2.fit) continue;
      std::string n1 = out[i]["variant"], n2 = out[j]["variant"];
      json c = analysis::toJson(analysis::crossing(*s1.fit, *s2.fit), n1, n2);
      c["first"] = n1;
      c["second"] = n2;
      c["scene"] = s1.first->scene;
      c["device_id"] = s1.first->deviceId;
      crossings.push_back(std::move(c));
    }
  }
  return json{{"capture", filter.jobId ? json(*filter.jobId) : json(nullptr)},
              {"metric", metric},
              {"model", "y = a + b * pixels (ordinary least squares)"},
              {"confidence", analysis::kCrossoverConfidence},
              {"poor_fit_r2", analysis::kPoorFitR2},
              {"interval_method", "t intervals for a and b (n - 2 df); Fieller for the crossing, delta method beside it (n1 + n2 - 4 df)"},
              {"series", std::move(out)},
              {"crossings", std::move(crossings)},
              {"truncated", !complete}};
}

}  // namespace tally::reports
