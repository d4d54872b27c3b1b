#include "reports/run_significance.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "analysis/run_config.hpp"
#include "analysis/stats.hpp"
#include "reports/run_rows.hpp"

namespace tally::reports {
namespace {

using nlohmann::json;

constexpr const char* kFrame = "frame";

Result<Samples> loadSamples(store::Store& store, int64_t runId) {
  auto rows = store.runs().samples(runId);
  if (!rows) return makeError(rows.error());
  Samples out;
  for (const auto& row : *rows) {
    auto sample = store.runs().sample(row.id);
    if (!sample) return makeError(sample.error());
    if (!*sample) continue;
    std::string key = analysis::cameraKey(row.camera);
    for (int n = 2; out.count(key); ++n) key = analysis::cameraKey(row.camera) + "#" + std::to_string(n);
    out.emplace(std::move(key), std::move(**sample));
  }
  return out;
}

const store::Pass* findPass(const store::Sample& s, const std::string& name) {
  for (const auto& p : s.passes) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

// The figure's per-frame times of each of `cameras`, or empty when a camera
// lacks them.
std::vector<std::vector<double>> perCamera(const Samples& samples, const std::vector<std::string>& cameras,
                                           const std::string& figure) {
  std::vector<std::vector<double>> out;
  for (const auto& key : cameras) {
    auto it = samples.find(key);
    if (it == samples.end()) return {};
    const std::vector<double>* times = nullptr;
    if (figure == kFrame) {
      times = &it->second.row.frameMsFrames;
    } else if (const store::Pass* p = findPass(it->second, figure)) {
      times = &p->gpuMsFrames;
    }
    if (!times || times->empty()) return {};
    out.push_back(*times);
  }
  return out;
}

// The same pooled over the cameras.
std::vector<double> pooled(const Samples& samples, const std::vector<std::string>& cameras, const std::string& figure) {
  std::vector<double> out;
  for (const auto& times : perCamera(samples, cameras, figure)) out.insert(out.end(), times.begin(), times.end());
  return out;
}

std::optional<double> medianOf(const std::vector<double>& times) {
  if (times.empty()) return std::nullopt;
  return analysis::spreadOf(times).median;
}

bool sameConfig(const analysis::RunConfig& a, const analysis::RunConfig& b) {
  return a.renderer == b.renderer && a.options == b.options && a.scene == b.scene && a.sceneParams == b.sceneParams &&
         a.device == b.device && a.counting == b.counting && a.width == b.width && a.height == b.height &&
         a.lights == b.lights;
}

// Earlier or later captures of `row`'s configuration (itself included, `skip`
// not), newest first, at most kMaxAcrossCaptureRepeats, with their samples.
Result<std::vector<std::pair<int64_t, Samples>>> repeatsOf(store::Store& store, const store::RunRow& row,
                                                           int64_t skip) {
  store::RunFilter filter;
  filter.variant = row.variant;
  filter.scene = row.scene;
  filter.width = row.width;
  filter.height = row.height;
  filter.deviceId = row.deviceId;
  bool complete = false;
  auto rows = selectRuns(store, filter, 1000, complete);
  if (!rows) return makeError(rows.error());
  const analysis::RunConfig config = runConfigOf(row);
  std::vector<std::pair<int64_t, Samples>> out;
  for (auto it = rows->rbegin(); it != rows->rend() && out.size() < kMaxAcrossCaptureRepeats; ++it) {
    if (it->id == skip || !sameConfig(runConfigOf(*it), config)) continue;
    auto samples = loadSamples(store, it->id);
    if (!samples) return makeError(samples.error());
    out.emplace_back(it->id, std::move(samples).value());
  }
  return out;
}

// The pooled standard deviation of log(median) over the repeats: one cell
// per configuration, shared camera and figure (the frame and every pass),
// holding each repeat's log median of that camera's per-frame times of that
// figure; the cells' squares about their means and their degrees of freedom
// (values - 1) add up. Two captures give one degree of freedom per cell
// instead of one in all (docs/statistics.md, "Across-capture noise").
std::optional<AcrossCapture> acrossCapture(const std::vector<const std::vector<std::pair<int64_t, Samples>>*>& groups,
                                           const std::vector<std::string>& cameras) {
  AcrossCapture out;
  double sumSquares = 0;
  for (const auto* group : groups) {
    std::map<std::pair<std::string, std::string>, std::vector<double>> cells;  // (camera, figure) -> logs
    std::vector<int64_t> ids;
    for (const auto& [id, samples] : *group) {
      bool used = false;
      for (const auto& camera : cameras) {
        auto it = samples.find(camera);
        if (it == samples.end()) continue;
        std::vector<std::string> figures{kFrame};
        for (const auto& pass : it->second.passes) figures.push_back(pass.name);
        for (const auto& figure : figures) {
          auto times = perCamera(samples, {camera}, figure);
          if (times.empty()) continue;
          double m = analysis::spreadOf(std::move(times.front())).median;
          if (!(m > 0) || !std::isfinite(m)) continue;  // a pass below the timer's resolution
          cells[{camera, figure}].push_back(std::log(m));
          used = true;
        }
      }
      if (used) ids.push_back(id);
    }
    size_t groupDf = 0;
    for (const auto& [key, logs] : cells) {
      if (logs.size() < 2) continue;
      double mean = 0;
      for (double l : logs) mean += l;
      mean /= static_cast<double>(logs.size());
      for (double l : logs) sumSquares += (l - mean) * (l - mean);
      groupDf += logs.size() - 1;
      ++out.cells;
    }
    if (groupDf == 0) continue;
    out.degreesOfFreedom += groupDf;
    out.captures = std::max(out.captures, ids.size());
    out.runs.insert(out.runs.end(), ids.begin(), ids.end());
  }
  if (out.degreesOfFreedom == 0) return std::nullopt;
  out.logSd = std::sqrt(sumSquares / static_cast<double>(out.degreesOfFreedom));
  return out;
}

// What the verdict says about the capture-to-capture noise it took into
// account, or empty when the repeats bound it.
std::string noiseNote(const std::optional<AcrossCapture>& across, bool sought) {
  if (!sought) return {};
  if (!across) {
    return "no configuration has 2 comparable captures: capture-to-capture noise is not bounded, only the "
           "frames' own";
  }
  if (across->captures >= kMinCapturesToBoundNoise) return {};
  return "only " + std::to_string(across->captures) +
         " repeated captures: too few to bound capture-to-capture noise (their spread pooled over " +
         std::to_string(across->cells) + " cameras and passes, " + std::to_string(across->degreesOfFreedom) +
         " degrees of freedom)";
}

// Counts: every line summed over the shared cameras, compared exactly.
void compareCountLines(const Samples& samplesA, const Samples& samplesB, RunSignificance& out) {
  std::map<std::string, std::pair<double, double>> lines;
  std::vector<std::string> order{"total"};
  auto addCounts = [&](const Samples& samples, bool isA) {
    for (const auto& key : out.cameras) {
      const store::Sample& s = samples.at(key);
      (isA ? lines["total"].first : lines["total"].second) += s.row.bytes;
      for (const auto& p : s.passes) {
        for (const auto& c : p.counters) {
          std::string line = lineKey(p.name, c);
          if (!lines.count(line)) order.push_back(line);
          (isA ? lines[line].first : lines[line].second) += c.count;
        }
      }
    }
  };
  addCounts(samplesA, true);
  addCounts(samplesB, false);
  out.countLines = order.size();
  // Compared as sums (exact), reported per frame as every other view shows
  // bytes: the mean over the shared cameras.
  const double cameras = static_cast<double>(out.cameras.size());
  for (const auto& line : order) {
    auto [a, b] = lines[line];
    if (analysis::compareCounts(a, b).verdict == analysis::CountVerdict::Changed)
      out.countChanges.push_back({line, a / cameras, b / cameras});
  }
}

json acrossJson(const std::optional<AcrossCapture>& a) {
  if (!a) return nullptr;
  return {{"runs", a->runs},
          {"log_sd", a->logSd},
          {"degrees_of_freedom", a->degreesOfFreedom},
          {"cells", a->cells},
          {"captures", a->captures}};
}

json figureJson(const FigureSignificance& f) {
  json out = analysis::toJson(f.time);
  out["across_capture"] = acrossJson(f.acrossCapture);
  out["strata"] = f.camerasAsStrata ? "cameras" : "none";
  out["noise_note"] = f.noiseNote.empty() ? json(nullptr) : json(f.noiseNote);
  out["run_median_a"] = f.runMedianA ? json(*f.runMedianA) : json(nullptr);
  out["run_median_b"] = f.runMedianB ? json(*f.runMedianB) : json(nullptr);
  return out;
}

}  // namespace

Result<std::optional<StoredRun>> loadStoredRun(store::Store& store, int64_t id) {
  auto run = store.runs().get(id);
  if (!run) return makeError(run.error());
  if (!*run) return std::optional<StoredRun>();
  auto samples = loadSamples(store, id);
  if (!samples) return makeError(samples.error());
  return std::optional<StoredRun>(StoredRun{std::move(**run), std::move(samples).value()});
}

Result<RunSignificance> runSignificance(store::Store& store, int64_t runA, int64_t runB,
                                        const SignificanceOptions& options) {
  auto a = loadStoredRun(store, runA);
  if (!a) return makeError(a.error());
  if (!*a) return makeError("no run " + std::to_string(runA));
  auto b = loadStoredRun(store, runB);
  if (!b) return makeError(b.error());
  if (!*b) return makeError("no run " + std::to_string(runB));
  return runSignificance(store, **a, **b, options);
}

Result<RunSignificance> runSignificance(store::Store& store, const StoredRun& storedA, const StoredRun& storedB,
                                        const SignificanceOptions& options) {
  const int64_t runA = storedA.run.row.id, runB = storedB.run.row.id;
  const Samples* samplesA = &storedA.samples;
  const Samples* samplesB = &storedB.samples;
  RunSignificance out;
  out.runA = runA;
  out.runB = runB;
  for (const auto& [key, sample] : *samplesA) {
    if (samplesB->count(key)) out.cameras.push_back(key);
  }
  if (out.cameras.empty()) {
    out.incomparable = "runs " + std::to_string(runA) + " and " + std::to_string(runB) +
                       " measured no camera in common; neither times nor counts can be compared";
    return out;
  }

  compareCountLines(*samplesA, *samplesB, out);

  // Repeats of each configuration (one group when both runs share it: B is
  // the capture under test, so it is left out).
  std::vector<std::pair<int64_t, Samples>> repeatsA, repeatsB;
  std::vector<const std::vector<std::pair<int64_t, Samples>>*> groups;
  if (options.acrossCapture) {
    bool same = sameConfig(runConfigOf(storedA.run.row), runConfigOf(storedB.run.row));
    auto a = repeatsOf(store, storedA.run.row, runB);
    if (!a) return makeError(a.error());
    repeatsA = std::move(a).value();
    groups.push_back(&repeatsA);
    if (!same) {
      auto b = repeatsOf(store, storedB.run.row, runA);
      if (!b) return makeError(b.error());
      repeatsB = std::move(b).value();
      groups.push_back(&repeatsB);
    }
  }

  // One across-capture spread for every figure, pooled over all of them.
  const std::optional<AcrossCapture> across =
      options.acrossCapture ? acrossCapture(groups, out.cameras) : std::optional<AcrossCapture>();

  // A figure's comparison, or why there is none.
  auto figure = [&](const std::string& name, std::string& missing) -> std::optional<FigureSignificance> {
    std::vector<double> a = pooled(*samplesA, out.cameras, name), b = pooled(*samplesB, out.cameras, name);
    // The runs' own medians, before any alignment: what the runs list and the trend show.
    const std::optional<double> runMedianA = medianOf(a), runMedianB = medianOf(b);
    if (options.camerasAsStrata && !a.empty() && !b.empty()) {
      std::vector<analysis::Stratum> strata;
      auto ca = perCamera(*samplesA, out.cameras, name), cb = perCamera(*samplesB, out.cameras, name);
      for (size_t c = 0; c < ca.size(); ++c) strata.push_back({std::move(ca[c]), std::move(cb[c])});
      auto aligned = analysis::alignStrata(strata);
      if (!aligned) {
        missing = aligned.error();
        return std::nullopt;
      }
      a = std::move(aligned->a);
      b = std::move(aligned->b);
    }
    if (a.empty() || b.empty()) {
      missing = "a shared camera has no per-frame times stored in one of the runs (runs stored before "
                "per-frame times were kept have none)";
      return std::nullopt;
    }
    if (a.size() < 2 || b.size() < 2) {
      missing = std::string("sample ") + (a.size() < 2 ? "A" : "B") + " has 1 frame time; a comparison needs at least 2";
      return std::nullopt;
    }
    FigureSignificance f;
    f.figure = name;
    f.camerasAsStrata = options.camerasAsStrata;
    f.runMedianA = runMedianA;
    f.runMedianB = runMedianB;
    analysis::CompareOptions compare = options.compare;
    f.acrossCapture = across;
    if (across) {
      compare.acrossCaptureLogSd = across->logSd;
      compare.acrossCaptureRuns = across->degreesOfFreedom + 1;
    }
    auto time = analysis::compareTimes(a, b, compare);
    if (!time) {
      // Stored times the test cannot take: a pass below the timer's resolution reads 0 ms.
      missing = time.error();
      return std::nullopt;
    }
    f.time = std::move(time).value();
    f.noiseNote = noiseNote(across, options.acrossCapture);
    if (!f.noiseNote.empty()) f.time.reason += "; " + f.noiseNote;
    return f;
  };

  out.frame = figure(kFrame, out.frameMissing);
  for (const auto& p : samplesA->at(out.cameras.front()).passes) {
    std::string missing;
    if (auto pass = figure(p.name, missing)) {
      out.passes.push_back(std::move(*pass));
    } else if (findPass(samplesB->at(out.cameras.front()), p.name)) {
      out.passesMissing.emplace_back(p.name, missing);
    }
  }
  return out;
}

json toJson(const RunSignificance& s) {
  if (!s.incomparable.empty()) return {{"run_a", s.runA}, {"run_b", s.runB}, {"cameras", 0}, {"error", s.incomparable}};
  json passes = json::array(), changes = json::array();
  for (const auto& p : s.passes) {
    json j = figureJson(p);
    j["pass"] = p.figure;
    passes.push_back(std::move(j));
  }
  json missing = json::array();
  for (const auto& [pass, why] : s.passesMissing) missing.push_back({{"pass", pass}, {"reason", why}});
  for (const auto& c : s.countChanges) {
    changes.push_back({{"line", c.line}, {"a", c.a}, {"b", c.b}, {"delta", c.b - c.a}});
  }
  return {{"run_a", s.runA},
          {"run_b", s.runB},
          {"cameras", s.cameras.size()},
          {"frame", s.frame ? figureJson(*s.frame) : json(nullptr)},
          {"frame_missing", s.frame ? json(nullptr) : json(s.frameMissing)},
          {"passes", std::move(passes)},
          {"passes_missing", std::move(missing)},
          {"counts",
           {{"verdict", s.countsChanged() ? "changed" : "same"},
            {"lines", s.countLines},
            {"changes", std::move(changes)}}}};
}

}  // namespace tally::reports
