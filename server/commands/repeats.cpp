#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>

#include "analysis/repeats.hpp"
#include "commands/commands.hpp"

namespace tally::cli {

int runRepeats(const RepeatsArgs& args) {
  auto fail = [](const std::string& message) {
    std::cerr << "tallyd repeats: " << message << "\n";
    return 1;
  };
  std::vector<analysis::RepeatRun> runs;
  for (const auto& file : args.results) {
    std::ifstream in(file, std::ios::binary);
    if (!in) return fail(file + ": cannot open for reading");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    auto result = nlohmann::json::parse(text, nullptr, false);
    if (result.is_discarded()) return fail(file + ": not valid JSON");
    auto got = analysis::repeatRunsFromResult(result, file);
    if (!got) return fail(file + ": " + got.error());
    runs.insert(runs.end(), got->begin(), got->end());
  }
  auto groups = analysis::repeatGroups(runs);

  if (args.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& g : groups) {
      nlohmann::json ids = nlohmann::json::array();
      for (const auto* run : g.runs) ids.push_back(run->id);
      const auto& first = *g.runs.front();
      out.push_back({{"runs", ids},
                     {"renderer", first.renderer},
                     {"scene", first.scene},
                     {"width", first.width},
                     {"height", first.height},
                     {"counting", first.counting},
                     {"cameras", first.samples.size()},
                     {"frame_ms", analysis::frameMsJson(g)},
                     {"bytes", analysis::toJson(g.bytes)},
                     {"counts", analysis::toJson(g.counts)}});
    }
    std::cout << nlohmann::json{{"groups", out}, {"band_iqrs", analysis::kRepeatBandIqrs}}.dump(1) << "\n";
    return 0;
  }

  // One line per group: frame time across captures (median [q1, q3], range),
  // the within-run noise and band; then bytes and counts.
  std::printf("band: across-capture median -/+ %.1f x within-run IQR (docs/measurement.md, Repeatability)\n",
              analysis::kRepeatBandIqrs);
  std::printf("%-18s %-10s %-9s %-7s %4s  %-44s %9s %7s  %-14s %s\n", "renderer", "scene", "resolution",
              "mode", "runs", "frame_ms_median per run", "median", "IQR", "within IQR",
              "agrees  bytes  counts");
  for (const auto& g : groups) {
    const auto& first = *g.runs.front();
    std::string perRun;
    for (double v : g.frameMs.perRun) {
      char buf[24];
      std::snprintf(buf, sizeof buf, "%s%.4f", perRun.empty() ? "" : " ", v);
      perRun += buf;
    }
    std::string res = std::to_string(first.width) + "x" + std::to_string(first.height);
    char noise[32];
    std::snprintf(noise, sizeof noise, "%.4f", g.frameMs.noise);
    std::printf("%-18s %-10s %-9s %-7s %4zu  %-44s %9.4f %7.4f  %-14s %-6s  %-5s  %s\n", first.renderer.c_str(),
                first.scene.c_str(), res.c_str(), first.counting.c_str(), g.runs.size(), perRun.c_str(),
                g.frameMs.across.median, g.frameMs.across.iqr(), noise, g.frameMs.agrees ? "yes" : "NO",
                g.bytes.agrees ? "yes" : "NO", g.counts.identical ? "identical" : g.counts.firstDifference.c_str());
  }
  if (groups.empty()) std::printf("(no two runs with one configuration)\n");
  return 0;
}

}  // namespace tally::cli
