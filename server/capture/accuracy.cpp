#include "capture/accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include "capture/stats.hpp"

namespace tally::capture {
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

std::string text(const json& j, const char* key) {
  if (!j.contains(key) || j[key].is_null()) return "";
  return j[key].is_string() ? j[key].get<std::string>() : j[key].dump();
}

}  // namespace

bool sameFrames(const RunCounts& a, const RunCounts& b) {
  if (a.renderer != b.renderer || a.scene != b.scene || a.sceneParams != b.sceneParams || a.device != b.device ||
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
    if (r.renderer == run.renderer && r.scene == run.scene) anyExact = true;
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
  if (!result.is_object() || !result.contains("runs") || !result["runs"].is_array()) {
    return makeError("not a capture result: no \"runs\" array");
  }
  std::string device = result.contains("device") && result["device"].is_object() ? text(result["device"], "name") : "";
  std::vector<RunCounts> out;
  for (size_t i = 0; i < result["runs"].size(); ++i) {
    const auto& r = result["runs"][i];
    std::string where = "runs[" + std::to_string(i) + "]";
    if (!r.is_object() || !r.contains("samples") || !r["samples"].is_array()) return makeError(where + ": no samples");
    RunCounts run;
    run.id = std::to_string(i);
    run.renderer = text(r, "renderer");
    run.scene = text(r, "scene");
    run.sceneParams = r.contains("scene_params") ? r["scene_params"].dump() : "";
    run.device = device;
    run.counting = r.contains("counting") ? text(r, "counting") : "exact";
    run.width = r.value("width", 0);
    run.height = r.value("height", 0);
    run.lights = r.value("lights", 0);
    for (const auto& s : r["samples"]) {
      SampleCounts sample;
      json camera = s.value("camera", json::object());
      camera.erase("index");
      camera.erase("label");
      sample.camera = camera.dump();
      sample.frameMs = s.value("frame_ms", 0.0);
      sample.frameMsInstrumented = s.value("frame_ms_instrumented", 0.0);
      for (const auto& pass : s.value("passes", json::array())) {
        for (const auto& line : pass.value("resources", json::array())) {
          std::string key = pass.value("name", "") + "/" + line.value("name", "") + " " + line.value("access", "");
          sample.bytes[key] += line.value("bytes", 0.0);
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

}  // namespace tally::capture
