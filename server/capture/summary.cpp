#include "capture/summary.hpp"

#include <cstdio>
#include <algorithm>
#include <map>
#include <vector>

namespace tally::capture {
namespace {

std::string human(double bytes) {
  const char* units[] = {"B", "KB", "MB", "GB", "TB"};
  int u = 0;
  while (bytes >= 1000 && u < 4) {
    bytes /= 1000;
    ++u;
  }
  char text[32];
  std::snprintf(text, sizeof text, u == 0 ? "%.0f %s" : "%.2f %s", bytes, units[u]);
  return text;
}

std::string format(const char* fmt, auto... args) {
  char line[512];
  std::snprintf(line, sizeof line, fmt, args...);
  return line;
}

struct Totals {
  double read = 0, written = 0, ms = 0, overhead = 0;
  double imageRead = 0, bufferRead = 0;  // the founding study counted image traffic only
  size_t samples = 0;
};

}  // namespace

std::string summarize(const nlohmann::json& result, const std::string& baseline) {
  std::string out;
  // Group runs by (scene, resolution); within a group compare renderers.
  std::map<std::string, std::vector<const nlohmann::json*>> groups;
  std::vector<std::string> order;
  for (const auto& run : result.at("runs")) {
    std::string key = run.at("scene").get<std::string>() + " " + std::to_string(run.at("width").get<int>()) + "x" +
                      std::to_string(run.at("height").get<int>());
    if (!groups.count(key)) order.push_back(key);
    groups[key].push_back(&run);
  }
  if (result.contains("device")) {
    out += "device: " + result["device"].value("name", std::string("?")) + " (" +
           result["device"].value("driverInfo", std::string("")) + ")\n";
  }
  for (const auto& key : order) {
    out += "\n=== " + key + " (bytes per frame, mean over cameras; counting " +
           groups[key].front()->value("counting", std::string("exact")) + ")\n";
    std::map<std::string, Totals> totals;
    for (const auto* run : groups[key]) {
      std::string renderer = run->at("renderer");
      out += "\n" + renderer + "\n";
      out += format("  %-12s %-28s %12s %12s %s\n", "pass", "resource", "read", "written", "source");
      // pass -> resource -> (read, written) summed over samples, then averaged.
      std::vector<std::string> passOrder;
      std::map<std::string, std::map<std::string, std::pair<double, double>>> table;
      std::map<std::string, std::string> sources;
      std::map<std::string, double> passMs;
      Totals& t = totals[renderer];
      std::map<std::string, bool> isBuffer;
      if (run->contains("resources")) {
        for (const auto& r : run->at("resources").at("list")) isBuffer[r.at("name")] = r.at("kind") == "buffer";
      }
      const auto& samples = run->at("samples");
      for (const auto& sample : samples) {
        t.ms += sample.value("frame_ms", 0.0);
        t.overhead += sample.value("overhead_ratio", 0.0);
        ++t.samples;
        for (const auto& pass : sample.at("passes")) {
          std::string p = pass.at("name");
          if (!table.count(p)) passOrder.push_back(p);
          passMs[p] += pass.value("gpu_ms", 0.0);
          for (const auto& r : pass.at("resources")) {
            auto& cell = table[p][r.at("name").get<std::string>()];
            double bytes = r.at("bytes").get<double>();
            (r.at("access") == "write" ? cell.second : cell.first) += bytes;
            sources[p + "/" + r.at("name").get<std::string>()] = r.value("source", std::string("counter"));
          }
        }
      }
      double n = samples.empty() ? 1.0 : double(samples.size());
      for (const auto& p : passOrder) {
        double passRead = 0, passWritten = 0;
        for (const auto& [resource, cell] : table[p]) {
          out += format("  %-12s %-28s %12s %12s %s\n", p.c_str(), resource.substr(0, 28).c_str(),
                        human(cell.first / n).c_str(), human(cell.second / n).c_str(),
                        sources[p + "/" + resource].c_str());
          passRead += cell.first / n;
          passWritten += cell.second / n;
          (isBuffer[resource] ? t.bufferRead : t.imageRead) += cell.first / n;
        }
        out += format("  %-12s %-28s %12s %12s %.3f ms\n", p.c_str(), "(pass total)", human(passRead).c_str(),
                      human(passWritten).c_str(), passMs[p] / n);
        t.read += passRead;
        t.written += passWritten;
      }
      t.ms /= n;
      t.overhead /= n;
    }
    std::string base = baseline.empty() ? groups[key].front()->at("renderer").get<std::string>() : baseline;
    if (!totals.count(base)) base = groups[key].front()->at("renderer").get<std::string>();
    const Totals& b = totals[base];
    out += "\n  totals per frame (ratios against " + base + "; image = textures, attachments, depth)\n";
    out += format("  %-18s %12s %8s %12s %8s %12s %9s %10s %9s\n", "renderer", "image read", "x", "buffer read", "x",
                  "written", "written x", "frame ms", "overhead");
    for (const auto* run : groups[key]) {
      std::string renderer = run->at("renderer");
      const Totals& t = totals[renderer];
      auto ratio = [](double value, double reference) { return reference > 0 ? value / reference : 0.0; };
      // An application's frames are timed under the layer only: no overhead to state.
      const std::string overhead = t.overhead > 0 ? format("%8.2fx", t.overhead) : format("%9s", "-");
      out += format("  %-18s %12s %8.2f %12s %8.2f %12s %9.2f %10.3f %s\n", renderer.c_str(),
                    human(t.imageRead).c_str(), ratio(t.imageRead, b.imageRead), human(t.bufferRead).c_str(),
                    ratio(t.bufferRead, b.bufferRead), human(t.written).c_str(), ratio(t.written, b.written), t.ms,
                    overhead.c_str());
    }
  }
  // Where the capture's time went (result "timing"), largest first.
  if (result.contains("timing") && result["timing"].is_object() && result["timing"].contains("total")) {
    const auto& timing = result["timing"];
    double total = timing["total"].get<double>();
    std::vector<std::pair<double, std::string>> phases;
    for (const auto& [phase, seconds] : timing.items()) {
      if (phase != "total" && seconds.is_number()) phases.emplace_back(seconds.get<double>(), phase);
    }
    std::sort(phases.rbegin(), phases.rend());
    out += format("\ncapture time %.1f s:\n", total);
    for (const auto& [seconds, phase] : phases) {
      out += format("  %-18s %8.2f s %5.1f%%\n", phase.c_str(), seconds, total > 0 ? 100.0 * seconds / total : 0.0);
    }
  }
  return out;
}

}  // namespace tally::capture
