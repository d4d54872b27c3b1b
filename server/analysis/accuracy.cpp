#include "analysis/accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include "analysis/stats.hpp"

namespace tally::analysis {
namespace {

using nlohmann::json;

// Adds one sample's lines to running sums; `worst` keeps the largest line error.
struct Sums {
  double run = 0, exact = 0, absDiff = 0;
  double worst = 0;
  std::string worstLine;

  void add(const std::map<std::string, double>& bytes, const std::map<std::string, double>& exactBytes) {
    std::set<std::string> lines;
    for (const auto& [line, b] : bytes) lines.insert(line);
    for (const auto& [line, b] : exactBytes) lines.insert(line);
    for (const auto& line : lines) {
      auto it = bytes.find(line);
      auto et = exactBytes.find(line);
      double b = it == bytes.end() ? 0.0 : it->second;
      double e = et == exactBytes.end() ? 0.0 : et->second;
      run += b;
      exact += e;
      absDiff += std::fabs(b - e);
      double relative = e > 0 ? std::fabs(b - e) / e : (b != 0 ? 1.0 : 0.0);
      if (relative > worst) {
        worst = relative;
        worstLine = line;
      }
    }
  }

  ErrorFigures figures() const {
    ErrorFigures f;
    f.total = exact > 0 ? std::fabs(run - exact) / exact : 0.0;
    f.l1 = exact > 0 ? absDiff / exact : 0.0;
    f.worst = worst;
    f.worstLine = worstLine;
    return f;
  }
};

double ratio(const SampleCounts& s) { return s.frameMs > 0 ? s.frameMsInstrumented / s.frameMs : 0.0; }

double medianRatio(const RunCounts& run) {
  std::vector<double> ratios;
  for (const auto& s : run.samples) ratios.push_back(ratio(s));
  return ratios.empty() ? 0.0 : spreadOf(ratios).median;
}

}  // namespace

bool sameFrames(const RunCounts& a, const RunCounts& b) {
  if (a.renderer != b.renderer || a.options != b.options || a.scene != b.scene || a.sceneParams != b.sceneParams || a.device != b.device ||
      a.width != b.width || a.height != b.height || a.lights != b.lights || a.samples.size() != b.samples.size()) {
    return false;
  }
  for (size_t i = 0; i < a.samples.size(); ++i) {
    if (a.samples[i].camera != b.samples[i].camera) return false;
  }
  return true;
}

Result<RunAccuracy> compareToExact(const RunCounts& run, const RunCounts& exact) {
  if (!sameFrames(run, exact)) return makeError("the runs do not measure the same frames");
  if (run.samples.empty()) return makeError("the run has no samples");
  RunAccuracy out;
  Sums all;
  double worst = 0;
  for (size_t i = 0; i < run.samples.size(); ++i) {
    Sums one;
    one.add(run.samples[i].bytes, exact.samples[i].bytes);
    all.add(run.samples[i].bytes, exact.samples[i].bytes);
    if (one.worst > worst) {
      worst = one.worst;
      out.worstSample = i;
    }
    out.samples.push_back({i, one.figures(), ratio(run.samples[i]), ratio(exact.samples[i])});
  }
  if (!(all.exact > 0)) return makeError("the exact run counted no bytes");
  out.errors = all.figures();
  out.overheadRatio = medianRatio(run);
  out.referenceOverheadRatio = medianRatio(exact);
  return out;
}

std::optional<size_t> findReference(const RunCounts& run, const std::vector<RunCounts>& runs, std::string* why) {
  std::optional<size_t> found, sameGroup;
  bool anyExact = false;
  for (size_t i = 0; i < runs.size(); ++i) {
    const auto& r = runs[i];
    if (r.counting != "exact") continue;
    if (r.renderer == run.renderer && r.options == run.options && r.scene == run.scene) anyExact = true;
    if (!sameFrames(run, r)) continue;
    found = i;
    if (r.group == run.group) sameGroup = i;
  }
  if (sameGroup) return sameGroup;
  if (found) return found;
  if (why) {
    *why = anyExact ? "no exact run of the same frames (resolution, scene parameters, device, lights or cameras differ)"
                    : "no exact run of this renderer and scene";
  }
  return std::nullopt;
}

Result<std::vector<RunCounts>> runCountsFromResult(const json& result) {
  auto runs = resultRuns(result);
  if (!runs) return makeError(runs.error());
  std::vector<RunCounts> out;
  for (const auto& [config, r] : *runs) {
    RunCounts run;
    static_cast<RunConfig&>(run) = config;
    for (const auto& s : (*r)["samples"]) {
      SampleCounts sample;
      sample.camera = cameraKey(s.value("camera", json::object()));
      sample.frameMs = s.value("frame_ms", 0.0);
      sample.frameMsInstrumented = s.value("frame_ms_instrumented", 0.0);
      for (const auto& pass : s.value("passes", json::array())) {
        for (const auto& line : pass.value("resources", json::array())) {
          sample.bytes[lineKey(pass, line)] += line.value("bytes", 0.0);
        }
      }
      run.samples.push_back(std::move(sample));
    }
    out.push_back(std::move(run));
  }
  return out;
}

std::vector<AccuracyRow> accuracyRows(const std::vector<RunCounts>& runs) {
  std::vector<AccuracyRow> rows;
  for (const auto& run : runs) {
    if (run.counting == "exact") continue;
    AccuracyRow row;
    row.run = &run;
    auto ref = findReference(run, runs, &row.reason);
    if (ref) {
      auto accuracy = compareToExact(run, runs[*ref]);
      if (accuracy) {
        row.reference = &runs[*ref];
        row.accuracy = std::move(accuracy).value();
      } else {
        row.reason = accuracy.error();
      }
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

json toJson(const ErrorFigures& errors) {
  return {{"total_error", errors.total},
          {"l1_error", errors.l1},
          {"worst_error", errors.worst},
          {"worst_resource", errors.worstLine.empty() ? json(nullptr) : json(errors.worstLine)}};
}

}  // namespace tally::analysis
