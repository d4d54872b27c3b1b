#include "reports/heatmap.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <numeric>
#include <set>
#include <tuple>

#include "analysis/image.hpp"
#include "analysis/significance.hpp"
#include "scenes/bvh.hpp"
#include "scenes/heatmap.hpp"
#include "scenes/spec.hpp"
#include "reports/run_rows.hpp"

namespace tally::reports {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

HeatmapAnswer fail(HeatmapFailure::Kind kind, std::string field, std::string message) {
  HeatmapAnswer a;
  a.failure = HeatmapFailure{kind, std::move(field), std::move(message)};
  return a;
}

constexpr auto kInvalid = HeatmapFailure::Kind::kInvalid;
constexpr auto kMissing = HeatmapFailure::Kind::kMissing;
constexpr auto kStore = HeatmapFailure::Kind::kStore;

std::string variantOf(const store::RunRow& r) { return r.variant.empty() ? r.renderer : r.variant; }

// A run with a layout in its notes; a grid beyond the spec's limits (a
// result from elsewhere) is not one.
bool isHeatmapRun(const store::RunRow& r) {
  if (!r.notes.is_object() || !r.notes.contains("heatmap") || !r.notes["heatmap"].is_object()) return false;
  const json& layout = r.notes["heatmap"];
  auto within = [&](const char* key) {
    return layout.contains(key) && layout[key].is_number_unsigned() && layout[key].get<uint64_t>() >= 1 &&
           layout[key].get<uint64_t>() <= std::max(scenes::kMaxHeatmapCells, scenes::kMaxHeatmapSegments);
  };
  return within("columns") && within("rows");
}

// Runs of one configuration but the variant: scene, its parameters,
// resolution, counting mode, device.
std::string configKey(const store::RunRow& r) {
  return json{r.scene, r.sceneParams, r.width, r.height, r.counting, r.deviceId}.dump();
}

std::string configLabel(const store::RunRow& r) {
  return r.scene + " " + std::to_string(r.width) + "x" + std::to_string(r.height) + " " + r.counting + " on " +
         r.deviceName + " (run " + std::to_string(r.id) + ")";
}

// A sample's cell: the camera's "heatmap" object.
std::optional<std::tuple<uint32_t, uint32_t, uint32_t>> cellOf(const json& camera) {
  if (!camera.is_object() || !camera.contains("heatmap") || !camera["heatmap"].is_object()) return std::nullopt;
  const json& h = camera["heatmap"];
  for (const char* key : {"column", "row", "yaw"}) {
    if (!h.contains(key) || !h[key].is_number_unsigned()) return std::nullopt;
  }
  return std::tuple{h["column"].get<uint32_t>(), h["row"].get<uint32_t>(), h["yaw"].get<uint32_t>()};
}

struct Cell {
  std::map<uint32_t, const store::SampleRow*> a, b;  // by yaw
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

json orNull(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

// The runs a map is drawn from: the variant asked for and, with versus, its
// counterpart of the same configuration (both point into `selected`).
struct MapRuns {
  std::vector<store::RunRow> selected;
  bool complete = false;
  const store::RunRow* a = nullptr;
  const store::RunRow* b = nullptr;
};

// Chooses the runs of q, or answers the failure naming the field that
// selects none of them or several.
std::optional<HeatmapAnswer> chooseRuns(store::Store& store, const HeatmapQuery& q, MapRuns& runs) {
  store::RunFilter filter;
  filter.jobId = q.capture;
  filter.scene = q.scene;
  filter.width = q.width;
  filter.height = q.height;
  auto selected = selectRuns(store, filter, kHeatmapMaxRuns, runs.complete);
  if (!selected) return fail(kStore, "", selected.error());
  runs.selected = std::move(selected).value();
  std::vector<const store::RunRow*> heatmapRuns;
  for (const auto& r : runs.selected) {
    if (isHeatmapRun(r) && (!q.counting || r.counting == *q.counting)) heatmapRuns.push_back(&r);
  }
  if (heatmapRuns.empty()) {
    bool any = std::any_of(runs.selected.begin(), runs.selected.end(), isHeatmapRun);
    if (!any && !q.scene && !q.width && !q.height && !q.counting) {
      return fail(kInvalid, "capture", "capture " + std::to_string(q.capture) + " is not a heatmap capture (its spec has no \"heatmap\")");
    }
    return fail(kInvalid, q.scene ? "scene" : q.counting ? "counting" : "width",
                "no heatmap run of capture " + std::to_string(q.capture) + " matches scene, width, height and counting");
  }
  std::set<std::string> variants;
  for (const auto* r : heatmapRuns) variants.insert(variantOf(*r));
  std::string known;
  for (const auto& v : variants) known += (known.empty() ? "'" : ", '") + v + "'";

  std::vector<const store::RunRow*> runsA;
  for (const auto* r : heatmapRuns)
    if (variantOf(*r) == q.renderer) runsA.push_back(r);
  if (runsA.empty()) {
    return fail(kInvalid, "renderer", "no heatmap run of '" + q.renderer + "' in capture " + std::to_string(q.capture) +
                                     " (its variants: " + known + ")");
  }
  if (runsA.size() > 1) {
    std::string which;
    for (const auto* r : runsA) which += (which.empty() ? "" : "; ") + configLabel(*r);
    return fail(kInvalid, "renderer", "capture " + std::to_string(q.capture) + " has " + std::to_string(runsA.size()) +
                                     " runs of '" + q.renderer + "' (" + which +
                                     "): choose one with scene, width, height or counting");
  }
  runs.a = runsA.front();
  if (q.versus) {
    for (const auto* r : heatmapRuns) {
      if (variantOf(*r) == *q.versus && configKey(*r) == configKey(*runs.a)) runs.b = r;
    }
    if (!runs.b) {
      return fail(kInvalid, "versus", "no heatmap run of '" + *q.versus + "' with the same scene, resolution, counting and device as " +
                                     configLabel(*runs.a) + " (the capture's variants: " + known + ")");
    }
  }
  return std::nullopt;
}

struct Measured {
  uint32_t column, row;
  double a;
  std::optional<double> b, ratio;
  std::optional<bool> significant;
  std::string verdict;
};

// What a map reads while it walks its cells: the samples of both runs placed
// by cell and yaw, and the per-frame times fetched as the tests need them.
struct MapCells {
  store::Store& store;
  const HeatmapQuery& q;
  const json& layout;
  const bool bytes;
  const bool versus;
  const std::optional<uint32_t> yawIndex;
  uint32_t columns = 0, rows = 0;
  std::vector<store::SampleRow> samplesA, samplesB;  // the cells point into these
  std::vector<Cell> cells;
  std::map<int64_t, std::vector<double>> frames;
  std::vector<Measured> measured;
  size_t empty = 0, incomplete = 0;

  void place(const std::vector<store::SampleRow>& samples, bool isB) {
    for (const auto& s : samples) {
      auto cell = cellOf(s.camera);
      if (!cell) continue;
      auto [c, r, y] = *cell;
      if (c >= columns || r >= rows) continue;
      (isB ? cells[size_t(r) * columns + c].b : cells[size_t(r) * columns + c].a)[y] = &s;
    }
  }

  // Per-frame times for the significance of a time difference.
  const std::vector<double>& framesOf(const store::SampleRow* s) {
    auto it = frames.find(s->id);
    if (it == frames.end()) {
      std::vector<double> ms;
      if (auto full = store.runs().sample(s->id); full && *full) ms = (*full)->row.frameMsFrames;
      it = frames.emplace(s->id, std::move(ms)).first;
    }
    return it->second;
  }

  double valueOf(const store::SampleRow* s) const { return bytes ? s->bytes : s->frameMs; }
};

// A cell's place in the layout: its column and row, and on a floor what the
// layout says of it.
json cellPlace(const MapCells& map, uint32_t c, uint32_t r) {
  json out = {{"column", c}, {"row", r}};
  if (map.layout.value("layout", "") == "floor") {
    const json& fl = map.layout["floor"];
    out["floor"] = fl.is_array() && r < fl.size() && c < fl[r].size() ? fl[r][c] : json(nullptr);
    const json& em = map.layout.contains("empty") ? map.layout["empty"] : json();
    out["empty"] = em.is_array() && r < em.size() && c < em[r].size() ? em[r][c] : json(nullptr);
  } else {
    out["floor"] = nullptr;
    out["empty"] = nullptr;
  }
  return out;
}

// A cell without a yaw both renderers measured.
void markUnmeasured(MapCells& map, const Cell& cell, json& out) {
  if (cell.a.empty() && cell.b.empty()) {
    if (out["empty"].is_null()) out["empty"] = "not_measured";
    ++map.empty;
  } else {
    out["empty"] = "incomplete";  // one renderer lacks this cell (a failed or partial run)
    ++map.incomplete;
  }
  for (const char* key : {"value_a", "value_b", "ratio", "yaw", "significance", "verdict", "significant"}) out[key] = nullptr;
  out["samples_a"] = json::array();
  out["samples_b"] = json::array();
}

// The yaws a cell's value is taken over: those both renderers measured (A's
// alone without versus), the one asked for, or with "worst" the yaw least
// favourable to B (largest B/A), or A's largest value.
std::vector<uint32_t> yawsUsed(const MapCells& map, const Cell& cell) {
  std::vector<uint32_t> both;
  for (const auto& [y, s] : cell.a) {
    if (!map.versus || cell.b.count(y)) both.push_back(y);
  }
  if (map.yawIndex) {
    both.erase(std::remove_if(both.begin(), both.end(), [&](uint32_t y) { return y != *map.yawIndex; }), both.end());
  }
  if (both.empty() || map.q.yaw != "worst") return both;
  uint32_t pick = both.front();
  double best = -1;
  for (uint32_t y : both) {
    double v = map.versus ? map.valueOf(cell.b.at(y)) / std::max(map.valueOf(cell.a.at(y)), 1e-300)
                          : map.valueOf(cell.a.at(y));
    if (v > best) best = v, pick = y;
  }
  return {pick};
}

// B against A in one cell: counts compared exactly, times tested with the
// yaws as strata.
void compareCell(const MapCells& map, const std::vector<analysis::Stratum>& strata, Measured& m, json& out) {
  if (map.bytes) {
    // Counts are deterministic: equal or not, no test.
    analysis::CountComparison cc = analysis::compareCounts(m.a, *m.b);
    m.verdict = analysis::toString(cc.verdict);
    m.significant = cc.verdict == analysis::CountVerdict::Changed;
    out["significance"] = analysis::toJson(cc);
  } else if (std::all_of(strata.begin(), strata.end(),
                         [](const analysis::Stratum& st) { return !st.a.empty() && !st.b.empty(); }) &&
             !strata.empty()) {
    // The yaws' frames aligned on each yaw's median before they are
    // pooled: looking one way costs more than another, and that
    // spread would hide a difference between renderers
    // (docs/statistics.md, "Cameras as strata").
    auto aligned = analysis::alignStrata(strata);
    auto tc = aligned ? analysis::compareTimes(aligned->a, aligned->b)
                      : Result<analysis::TimeComparison>(makeError(aligned.error()));
    if (tc) {
      m.verdict = analysis::toString(tc->verdict);
      m.significant = tc->verdict != analysis::Verdict::Same;
      out["significance"] = analysis::toJson(*tc);
      out["significance"]["strata"] = strata.size() > 1 ? "yaws" : "none";
    } else {
      out["significance"] = {{"error", tc.error()}};
    }
  } else {
    out["significance"] = {{"error", "per-frame times are not stored for these samples"}};
  }
  out["verdict"] = m.verdict.empty() ? json(nullptr) : json(m.verdict);
  out["significant"] = m.significant ? json(*m.significant) : json(nullptr);
}

// One measured cell: A's value (and B's, their ratio and its significance)
// over the yaws used.
void measureCell(MapCells& map, const Cell& cell, const std::vector<uint32_t>& used, uint32_t c, uint32_t r,
                 json& out) {
  double sumA = 0, sumB = 0;
  json idsA = json::array(), idsB = json::array();
  std::vector<analysis::Stratum> strata;  // one per yaw: a yaw's frames against the same yaw's
  for (uint32_t y : used) {
    sumA += map.valueOf(cell.a.at(y));
    idsA.push_back(cell.a.at(y)->id);
    if (map.versus) {
      sumB += map.valueOf(cell.b.at(y));
      idsB.push_back(cell.b.at(y)->id);
      if (!map.bytes) {
        strata.push_back({map.framesOf(cell.a.at(y)), map.framesOf(cell.b.at(y))});
      }
    }
  }
  Measured m{c, r, sumA / double(used.size()), std::nullopt, std::nullopt, std::nullopt, ""};
  out["value_a"] = m.a;
  out["yaw"] = used.size() == 1 ? json(used.front()) : json(nullptr);
  out["yaws"] = used;
  out["samples_a"] = idsA;
  out["samples_b"] = idsB;
  out["significance"] = nullptr;
  out["verdict"] = nullptr;
  out["significant"] = nullptr;
  if (map.versus) {
    m.b = sumB / double(used.size());
    m.ratio = m.a > 0 ? std::optional<double>(*m.b / m.a) : std::nullopt;
    out["value_b"] = *m.b;
    out["ratio"] = orNull(m.ratio);
    compareCell(map, strata, m, out);
  } else {
    out["value_b"] = nullptr;
    out["ratio"] = nullptr;
  }
  map.measured.push_back(m);
}

// Every cell of the layout, row by row.
json cellsJson(MapCells& map) {
  json out = json::array();
  for (uint32_t r = 0; r < map.rows; ++r) {
    for (uint32_t c = 0; c < map.columns; ++c) {
      const Cell& cell = map.cells[size_t(r) * map.columns + c];
      json one = cellPlace(map, c, r);
      std::vector<uint32_t> used = yawsUsed(map, cell);
      if (used.empty()) {
        markUnmeasured(map, cell, one);
      } else {
        measureCell(map, cell, used, c, r, one);
      }
      out.push_back(std::move(one));
    }
  }
  return out;
}

json cellRef(const Measured& m, double v) { return json{{"column", m.column}, {"row", m.row}, {"value", v}}; }

// B against A over the cells with a ratio: how many differ, which way, and
// where B gains most.
void summarizeRatios(const std::vector<Measured>& measured, json& summary) {
  std::vector<const Measured*> withRatio;
  for (const auto& m : measured)
    if (m.ratio) withRatio.push_back(&m);
  size_t significant = 0, bLower = 0, bHigher = 0;
  for (const auto* m : withRatio) {
    if (m->significant && *m->significant) {
      ++significant;
      (*m->ratio < 1 ? bLower : bHigher)++;
    }
  }
  summary["significant"] = significant;
  summary["b_lower"] = bLower;    // significant cells where B's value is lower (B wins)
  summary["b_higher"] = bHigher;  // ... higher (A wins)
  summary["not_significant"] = withRatio.size() - significant;
  if (withRatio.empty()) {
    summary["ratio"] = nullptr;
    summary["b_best_significant"] = nullptr;
    return;
  }
  std::vector<double> ratios;
  double logSum = 0;
  for (const auto* m : withRatio) {
    ratios.push_back(*m->ratio);
    logSum += std::log(*m->ratio);
  }
  auto [lo, hi] = std::minmax_element(withRatio.begin(), withRatio.end(),
                                      [](const Measured* x, const Measured* y) { return *x->ratio < *y->ratio; });
  summary["ratio"] = {{"min", cellRef(**lo, *(*lo)->ratio)},
                      {"max", cellRef(**hi, *(*hi)->ratio)},
                      {"median", median(ratios)},
                      {"geometric_mean", std::exp(logSum / double(ratios.size()))}};
  // The best cell for B among the significant ones (null when none is).
  const Measured* best = nullptr;
  for (const auto* m : withRatio) {
    if (m->significant && *m->significant && *m->ratio < 1 && (!best || *m->ratio < *best->ratio)) best = m;
  }
  summary["b_best_significant"] = best ? cellRef(*best, *best->ratio) : json(nullptr);
}

// The summary: where B gains most and loses most, how many cells differ.
json summaryJson(const MapCells& map) {
  json summary = {{"cells", size_t(map.columns) * map.rows}, {"cells_measured", map.measured.size()},
                  {"cells_empty", map.empty}, {"cells_incomplete", map.incomplete}};
  if (!map.measured.empty()) {
    std::vector<double> values;
    for (const auto& m : map.measured) values.push_back(m.a);
    auto [lo, hi] = std::minmax_element(map.measured.begin(), map.measured.end(),
                                        [](const Measured& x, const Measured& y) { return x.a < y.a; });
    summary["a"] = {{"min", cellRef(*lo, lo->a)}, {"max", cellRef(*hi, hi->a)}, {"median", median(values)}};
  }
  if (map.versus) summarizeRatios(map.measured, summary);
  return summary;
}

}  // namespace

HeatmapAnswer heatmapMap(store::Store& store, const HeatmapQuery& q) {
  const bool bytes = q.metric == "bytes";
  if (!bytes && q.metric != "frame_ms") return fail(kInvalid, "metric", "must be frame_ms or bytes");
  std::optional<uint32_t> yawIndex;
  if (q.yaw != "mean" && q.yaw != "worst") {
    bool digits = !q.yaw.empty() && q.yaw.size() <= 3 && q.yaw.find_first_not_of("0123456789") == std::string::npos;
    if (!digits) return fail(kInvalid, "yaw", "must be mean, worst or a yaw index (0, 1, ...), got '" + q.yaw + "'");
    yawIndex = uint32_t(std::stoul(q.yaw));
  }
  if (q.versus && *q.versus == q.renderer) return fail(kInvalid, "versus", "must name another variant than renderer");

  MapRuns runs;
  if (auto failed = chooseRuns(store, q, runs)) return std::move(*failed);
  const store::RunRow& runA = *runs.a;
  const store::RunRow* runB = runs.b;
  const json& layout = runA.notes["heatmap"];
  const size_t yaws = layout.contains("yaws_deg") && layout["yaws_deg"].is_array() ? layout["yaws_deg"].size() : 1;
  if (yawIndex && *yawIndex >= yaws) {
    return fail(kInvalid, "yaw", "must be mean, worst or a yaw index below " + std::to_string(yaws) + ", got " + q.yaw);
  }

  MapCells map{store, q, layout, bytes, runB != nullptr, yawIndex};
  map.columns = layout["columns"].get<uint32_t>();
  map.rows = layout["rows"].get<uint32_t>();
  auto samplesA = store.runs().samples(runA.id);
  if (!samplesA) return fail(kStore, "", samplesA.error());
  map.samplesA = std::move(samplesA).value();
  if (runB) {
    auto listed = store.runs().samples(runB->id);
    if (!listed) return fail(kStore, "", listed.error());
    map.samplesB = std::move(listed).value();
  }
  map.cells.resize(size_t(map.columns) * map.rows);
  map.place(map.samplesA, false);
  map.place(map.samplesB, true);
  json cells = cellsJson(map);

  const bool floorLayout = layout.value("layout", "") == "floor";
  json body = {{"capture", q.capture},
               {"renderer", q.renderer},
               {"versus", q.versus ? json(*q.versus) : json(nullptr)},
               {"metric", q.metric},
               {"yaw", q.yaw},  // as asked: mean, worst or the index
               {"scene", runA.scene},
               {"width", runA.width},
               {"height", runA.height},
               {"counting", runA.counting},
               {"device", runA.deviceName},
               {"runs", {{"a", runA.id}, {"b", runB ? json(runB->id) : json(nullptr)}}},
               {"confidence", 0.95},
               {"ratio", runB ? json("versus / renderer: below 1, versus is lower (faster, or fewer bytes)") : json(nullptr)},
               {"layout", layout},
               {"topdown", floorLayout ? json("/api/heatmap/" + std::to_string(q.capture) +
                                              "/topdown.png?scene=" + runA.scene)
                                       : json(nullptr)},
               {"cells", std::move(cells)},
               {"summary", summaryJson(map)},
               {"truncated", !runs.complete}};
  // The layout's scene spec names a file on the daemon's host: not served.
  body["layout"].erase("scene");
  HeatmapAnswer answer;
  answer.body = std::move(body);
  return answer;
}

namespace {

// Plans are rendered once per capture and scene (a second or so for Sponza).
struct PlanCache {
  std::mutex mutex;
  std::map<std::string, std::vector<uint8_t>> pngs;
  std::vector<std::string> order;  // oldest first
  static constexpr size_t kEntries = 16;
};
PlanCache& planCache() {
  static PlanCache cache;
  return cache;
}

// A glTF file is read again only from inside a --scenes folder.
bool insideFolders(const std::string& file, const std::vector<fs::path>& folders) {
  std::error_code ec;
  fs::path real = fs::canonical(file, ec);
  if (ec) return false;
  for (const auto& folder : folders) {
    fs::path root = fs::canonical(folder, ec);
    if (ec) continue;
    auto f = real.begin();
    bool inside = true;
    for (auto d = root.begin(); d != root.end(); ++d, ++f) {
      if (d->empty()) continue;
      if (f == real.end() || *f != *d) {
        inside = false;
        break;
      }
    }
    if (inside) return true;
  }
  return false;
}

}  // namespace

HeatmapAnswer heatmapTopDown(store::Store& store, int64_t capture, const std::optional<std::string>& scene,
                             const std::vector<fs::path>& sceneFolders) {
  store::RunFilter filter;
  filter.jobId = capture;
  filter.scene = scene;
  bool complete = false;
  auto selected = selectRuns(store, filter, kHeatmapMaxRuns, complete);
  if (!selected) return fail(kStore, "", selected.error());
  std::map<std::string, const store::RunRow*> byScene;
  for (const auto& r : *selected)
    if (isHeatmapRun(r)) byScene.emplace(r.scene, &r);
  if (byScene.empty()) {
    if (scene) return fail(kMissing, "scene", "capture " + std::to_string(capture) + " has no heatmap run on scene '" + *scene + "'");
    return fail(kMissing, "capture", "capture " + std::to_string(capture) + " is not a heatmap capture");
  }
  if (byScene.size() > 1) {
    std::string names;
    for (const auto& [name, r] : byScene) names += (names.empty() ? "" : ", ") + name;
    return fail(kInvalid, "scene", "capture " + std::to_string(capture) + " has heatmaps on several scenes (" + names +
                                  "): choose one with scene");
  }
  const store::RunRow& run = *byScene.begin()->second;
  const json& layout = run.notes["heatmap"];
  if (layout.value("layout", "") != "floor") {
    return fail(kMissing, "capture", "the " + layout.value("layout", std::string("?")) +
                                    " layout has no top-down plan (it is drawn as a longitude/latitude map)");
  }
  const std::string key = std::to_string(capture) + "/" + run.scene;
  {
    PlanCache& cache = planCache();
    std::lock_guard lock(cache.mutex);
    if (auto it = cache.pngs.find(key); it != cache.pngs.end()) {
      HeatmapAnswer a;
      a.png = it->second;
      return a;
    }
  }
  const json sceneSpec = layout.contains("scene") ? layout["scene"] : json(nullptr);
  if (sceneSpec.is_null()) return fail(kMissing, "scene", "the heatmap's layout does not say which scene it was placed on");
  if (sceneSpec.is_object() && sceneSpec.contains("gltf")) {
    if (!sceneSpec["gltf"].is_string() || !insideFolders(sceneSpec["gltf"].get<std::string>(), sceneFolders)) {
      return fail(kMissing, "scene", "the scene's glTF file is not inside this daemon's --scenes folders (or is gone)");
    }
  }
  auto loaded = scenes::makeSceneGeometry(sceneSpec);
  if (!loaded) return fail(kMissing, "scene", "the scene cannot be loaded again: " + loaded.error());
  scenes::Bvh bvh = scenes::Bvh::build(*loaded);
  auto image = scenes::renderTopDown(*loaded, bvh, layout);
  if (!image) return fail(kMissing, "capture", "no top-down plan: " + image.error());
  HeatmapAnswer a;
  a.png = analysis::encodePng(image->rgba, image->width, image->height);
  PlanCache& cache = planCache();
  std::lock_guard lock(cache.mutex);
  if (!cache.pngs.count(key)) {
    cache.pngs[key] = a.png;
    cache.order.push_back(key);
    if (cache.order.size() > PlanCache::kEntries) {
      cache.pngs.erase(cache.order.front());
      cache.order.erase(cache.order.begin());
    }
  }
  return a;
}

}  // namespace tally::reports
