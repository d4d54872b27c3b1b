#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <iterator>

#include "analysis/accuracy.hpp"
#include "commands/commands.hpp"

namespace tally::cli {
namespace {

std::string fixed(double value, const char* format) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, value);
  return buf;
}

}  // namespace

int runAccuracy(const AccuracyArgs& args) {
  auto fail = [](const std::string& message) {
    std::cerr << "tallyd accuracy: " << message << "\n";
    return 1;
  };
  std::ifstream in(args.result, std::ios::binary);
  if (!in) return fail(args.result + ": cannot open for reading");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  auto result = nlohmann::json::parse(text, nullptr, false);
  if (result.is_discarded()) return fail(args.result + ": not valid JSON");
  auto runs = analysis::runCountsFromResult(result);
  if (!runs) return fail(args.result + ": " + runs.error());
  auto rows = analysis::accuracyRows(*runs);

  if (args.json) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& row : rows) {
      nlohmann::json j = {{"run", std::stoi(row.run->id)},
                          {"renderer", row.run->renderer},
                          {"scene", row.run->scene},
                          {"width", row.run->width},
                          {"height", row.run->height},
                          {"counting", row.run->counting},
                          {"samples", row.run->samples.size()}};
      if (!row.accuracy) {
        j["reference"] = nullptr;
        j["reason"] = row.reason;
      } else {
        const auto& a = *row.accuracy;
        j["reference"] = std::stoi(row.reference->id);
        j["overhead_ratio"] = a.overheadRatio;
        j["reference_overhead_ratio"] = a.referenceOverheadRatio;
        j.update(analysis::toJson(a.errors));
        j["worst_sample"] = a.worstSample;
        nlohmann::json samples = nlohmann::json::array();
        for (const auto& s : a.samples) {
          nlohmann::json sj = analysis::toJson(s.errors);
          sj["index"] = s.index;
          sj["overhead_ratio"] = s.overheadRatio;
          sj["reference_overhead_ratio"] = s.referenceOverheadRatio;
          samples.push_back(std::move(sj));
        }
        j["per_sample"] = std::move(samples);
      }
      out.push_back(std::move(j));
    }
    std::cout << out.dump(1) << "\n";
    return 0;
  }

  // The table: one line per non-exact run; the exact reference's own overhead
  // on a line of its own so that every mode's cost is visible.
  std::printf("%-18s %-10s %-10s %-11s %9s %11s %11s %11s  %s\n", "renderer", "scene", "resolution", "mode",
              "overhead", "total_err", "l1_err", "worst_err", "worst resource");
  std::vector<const analysis::RunCounts*> shownExact;
  for (const auto& row : rows) {
    std::string res = std::to_string(row.run->width) + "x" + std::to_string(row.run->height);
    if (!row.accuracy) {
      std::printf("%-18s %-10s %-10s %-11s  (%s)\n", row.run->renderer.c_str(), row.run->scene.c_str(), res.c_str(),
                  row.run->counting.c_str(), row.reason.c_str());
      continue;
    }
    const auto& a = *row.accuracy;
    if (std::find(shownExact.begin(), shownExact.end(), row.reference) == shownExact.end()) {
      shownExact.push_back(row.reference);
      std::printf("%-18s %-10s %-10s %-11s %9s %11s %11s %11s  %s\n", row.run->renderer.c_str(),
                  row.run->scene.c_str(), res.c_str(), "exact", fixed(a.referenceOverheadRatio, "%.3f").c_str(), "0",
                  "0", "0", "-");
    }
    std::printf("%-18s %-10s %-10s %-11s %9s %11s %11s %11s  %s\n", row.run->renderer.c_str(),
                row.run->scene.c_str(), res.c_str(), row.run->counting.c_str(),
                fixed(a.overheadRatio, "%.3f").c_str(), fixed(a.errors.total, "%.3e").c_str(),
                fixed(a.errors.l1, "%.3e").c_str(), fixed(a.errors.worst, "%.3e").c_str(),
                a.errors.worstLine.empty() ? "-" : a.errors.worstLine.c_str());
  }
  if (rows.empty()) std::printf("(no run in a mode other than exact)\n");
  return 0;
}

}  // namespace tally::cli
