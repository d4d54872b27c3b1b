#include "analysis/repeats.hpp"

#include <cmath>
#include <cstdio>

namespace tally::analysis {
namespace {

using nlohmann::json;

std::string number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

}  // namespace

std::string configurationKey(const RepeatRun& run) {
  json cameras = json::array();
  for (const auto& s : run.samples) cameras.push_back({s.camera, s.frames});
  return json{run.renderer, run.options, run.scene, run.sceneParams, run.width, run.height, run.device, run.counting, run.lights,
              cameras}
      .dump();
}

RunFrameMs runFrameMs(const RepeatRun& run) {
  RunFrameMs out;
  std::vector<double> times, medians;
  bool everyFrame = !run.samples.empty();
  for (const auto& s : run.samples) {
    medians.push_back(s.frameMs);
    everyFrame = everyFrame && !s.frameTimes.empty();
    times.insert(times.end(), s.frameTimes.begin(), s.frameTimes.end());
  }
  const bool pooled = everyFrame;
  MedianInterval m = medianInterval(pooled ? std::move(times) : std::move(medians));
  if (!m.median) return out;
  out.median = *m.median;
  if (pooled) {
    out.lower = m.lower;
    out.upper = m.upper;
    out.frames = m.n;
  }
  out.source = pooled ? "frames" : "samples";
  return out;
}

RepeatFigure repeatFigure(std::vector<double> perRun, const std::vector<std::vector<double>>& iqrsPerRun) {
  RepeatFigure f;
  f.perRun = std::move(perRun);
  f.across = spreadOf(f.perRun);
  std::vector<double> iqrs;
  for (const auto& run : iqrsPerRun) iqrs.insert(iqrs.end(), run.begin(), run.end());
  f.noise = spreadOf(iqrs).median;
  f.low = f.across.median - kRepeatBandIqrs * f.noise;
  f.high = f.across.median + kRepeatBandIqrs * f.noise;
  f.agrees = !f.perRun.empty();
  for (double v : f.perRun) f.agrees = f.agrees && v >= f.low && v <= f.high;
  return f;
}

RepeatFigure repeatFigure(const std::vector<std::vector<double>>& valuesPerRun,
                          const std::vector<std::vector<double>>& iqrsPerRun) {
  std::vector<double> perRun;
  for (const auto& values : valuesPerRun) perRun.push_back(spreadOf(values).median);
  return repeatFigure(std::move(perRun), iqrsPerRun);
}

double runMeanBytes(const RepeatRun& run) {
  double sum = 0;
  for (const auto& s : run.samples) sum += s.bytes;
  return run.samples.empty() ? 0 : sum / double(run.samples.size());
}

CountAgreement compareCounts(const std::vector<const RepeatRun*>& runs) {
  CountAgreement c;
  if (runs.empty()) return c;
  const RepeatRun& first = *runs.front();
  for (const auto& s : first.samples) c.counters += s.counts.size();
  for (size_t r = 1; r < runs.size() && c.identical; ++r) {
    const RepeatRun& other = *runs[r];
    if (other.samples.size() != first.samples.size()) {
      c.identical = false;
      c.firstDifference = "run " + other.id + ": " + std::to_string(other.samples.size()) + " samples, not " +
                          std::to_string(first.samples.size());
      break;
    }
    for (size_t i = 0; i < first.samples.size() && c.identical; ++i) {
      const auto& a = first.samples[i].counts;
      const auto& b = other.samples[i].counts;
      std::string where = "run " + other.id + " camera " + std::to_string(i) + ": ";
      for (const auto& [line, count] : a) {
        auto it = b.find(line);
        if (it == b.end() || it->second != count) {
          c.identical = false;
          c.firstDifference = where + line + ": " + number(count) + " != " +
                              (it == b.end() ? std::string("absent") : number(it->second));
          break;
        }
      }
      if (c.identical && a.size() != b.size()) {
        for (const auto& [line, count] : b) {
          if (!a.count(line)) {
            c.identical = false;
            c.firstDifference = where + line + ": absent != " + number(count);
            break;
          }
        }
      }
    }
  }
  return c;
}

std::vector<RepeatGroup> repeatGroups(const std::vector<RepeatRun>& runs) {
  std::vector<std::string> order;
  std::map<std::string, std::vector<const RepeatRun*>> byKey;
  for (const auto& run : runs) {
    if (run.samples.empty()) continue;
    std::string key = configurationKey(run);
    auto [it, inserted] = byKey.try_emplace(key);
    if (inserted) order.push_back(key);
    it->second.push_back(&run);
  }
  std::vector<RepeatGroup> groups;
  for (const auto& key : order) {
    const auto& members = byKey[key];
    if (members.size() < 2) continue;
    RepeatGroup g;
    g.runs = members;
    std::vector<std::vector<double>> msIqr, bytesIqr;
    std::vector<double> ms, bytes;
    for (const RepeatRun* run : members) {
      g.frameMsOfRuns.push_back(runFrameMs(*run));
      ms.push_back(g.frameMsOfRuns.back().median);
      bytes.push_back(runMeanBytes(*run));
      msIqr.emplace_back();
      bytesIqr.emplace_back();
      for (const auto& s : run->samples) {
        msIqr.back().push_back(s.frameMsIqr);
        bytesIqr.back().push_back(s.bytesIqr);
      }
    }
    g.frameMs = repeatFigure(std::move(ms), msIqr);
    g.frameMs.statistic = kFrameMsStatistic;
    g.bytes = repeatFigure(std::move(bytes), bytesIqr);
    g.bytes.statistic = kBytesStatistic;
    g.counts = compareCounts(members);
    groups.push_back(std::move(g));
  }
  return groups;
}

Result<std::vector<RepeatRun>> repeatRunsFromResult(const json& result, const std::string& name) {
  auto runs = resultRuns(result);
  if (!runs) return makeError(runs.error());
  std::vector<RepeatRun> out;
  for (const auto& [config, r] : *runs) {
    RepeatRun run;
    static_cast<RunConfig&>(run) = config;
    run.id = name + "#" + config.id;
    for (const auto& s : (*r)["samples"]) {
      RepeatSample sample;
      sample.camera = cameraKey(s.value("camera", json::object()));
      sample.frames = s.value("frames", 0);
      sample.frameMs = s.value("frame_ms", 0.0);
      sample.frameMsIqr = iqrOf(s.value("frame_ms_spread", json()));
      const json frames = s.value("frame_ms_frames", json::array());
      if (frames.is_array()) {
        for (const auto& t : frames)
          if (t.is_number()) sample.frameTimes.push_back(t.get<double>());
      }
      for (const auto& pass : s.value("passes", json::array())) {
        for (const auto& line : pass.value("resources", json::array())) {
          double count = line.value("count", 0.0), bytes = line.value("bytes", 0.0);
          sample.counts[lineKey(pass, line)] += count;
          sample.bytes += bytes;
          if (count > 0) sample.bytesIqr += iqrOf(line.value("count_spread", json())) * bytes / count;
        }
      }
      run.samples.push_back(std::move(sample));
    }
    out.push_back(std::move(run));
  }
  return out;
}

json toJson(const RepeatFigure& f) {
  return {{"statistic", f.statistic}, {"per_run", f.perRun}, {"median", f.across.median},
          {"q1", f.across.q1},        {"q3", f.across.q3},   {"iqr", f.across.iqr()},
          {"min", f.across.min},      {"max", f.across.max}, {"noise_iqr", f.noise},
          {"band_low", f.low},        {"band_high", f.high}, {"agrees", f.agrees}};
}

json frameMsJson(const RepeatGroup& g) {
  json out = toJson(g.frameMs);
  json lower = json::array(), upper = json::array(), source = json::array();
  auto opt = [](const std::optional<double>& v) { return v ? json(*v) : json(nullptr); };
  for (const auto& run : g.frameMsOfRuns) {
    lower.push_back(opt(run.lower));
    upper.push_back(opt(run.upper));
    source.push_back(run.source);
  }
  out["per_run_lower"] = std::move(lower);
  out["per_run_upper"] = std::move(upper);
  out["per_run_source"] = std::move(source);
  return out;
}

json toJson(const CountAgreement& c) {
  return {{"identical", c.identical},
          {"counters", c.counters},
          {"first_difference", c.firstDifference.empty() ? json(nullptr) : json(c.firstDifference)}};
}

}  // namespace tally::analysis
