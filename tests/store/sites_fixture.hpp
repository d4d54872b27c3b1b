// Sites, draws and materials added to a capture result (docs/result-schema.md,
// "Sites, draws and materials"), computed from the result's own resource
// lines so that every sum holds: a line's sites sum to the line's bytes, a
// pass's draws (the rest included) sum to the pass's bytes, and each
// material is the sum of its draws. Shared by the store, service and client
// tests.
#pragma once

#include <map>
#include <string>

#include <nlohmann/json.hpp>

namespace tally::store::testing {

struct SiteOptions {
  int sitesPerLine = 3;  // sites per counted resource line
  int drawsPerPass = 12;
  bool foldDraws = true;  // keep the heaviest 256 and sum the rest, as the capture does
};

// The shader of a pass, as the fixture names it.
inline std::string fixtureShader(const std::string& pass) { return pass + ".frag.glsl"; }

// A source of `lines` lines; line n reads "  color += texture(map_n, uv); // n".
inline std::string fixtureSource(const std::string& name, int lines) {
  std::string text = "#version 460\n// " + name + "\n";
  for (int n = 3; n <= lines; ++n) text += "  color += texture(map_" + std::to_string(n) + ", uv);  // " + std::to_string(n) + "\n";
  return text;
}

// Sites for one pass: each counted line split over sitesPerLine sites with
// weights 1, 2, 3, ... (the last takes what is left, so the sum is the
// line's); site k of line l sits on source line 3 + l, except every third
// site, which sits on a line of its own, and the fourth site of each pass
// has no line at all.
inline nlohmann::json fixtureSites(const nlohmann::json& pass, const SiteOptions& options, int* maxLine) {
  nlohmann::json sites = nlohmann::json::array();
  int lineNo = 0, instruction = 10;
  for (const auto& line : pass["resources"]) {
    if (line.value("source", "counter") != "counter") continue;
    double weights = options.sitesPerLine * (options.sitesPerLine + 1) / 2.0;
    double bytesLeft = line["bytes"], countLeft = line["count"];
    for (int k = 0; k < options.sitesPerLine; ++k) {
      bool last = k + 1 == options.sitesPerLine;
      double bytes = last ? bytesLeft : double(line["bytes"]) * (k + 1) / weights;
      double count = last ? countLeft : double(line["count"]) * (k + 1) / weights;
      bytesLeft -= bytes;
      countLeft -= count;
      int source = k % 3 == 2 ? 3 + 100 + lineNo * 10 + k : 3 + lineNo;
      nlohmann::json site = {{"shader", fixtureShader(pass["name"])},
                             {"stage", "fragment"},
                             {"entry_point", "main"},
                             {"instruction", instruction},
                             {"opcode", "OpImageSampleImplicitLod"},
                             {"resource", line["name"]},
                             {"access", line["access"]},
                             {"kind", line.value("kind", "texture")},
                             {"file", fixtureShader(pass["name"])},
                             {"line", source},
                             {"disassembly", "%" + std::to_string(instruction) + " = OpImageSampleImplicitLod %v4float %a %b"},
                             {"count", count},
                             {"bytes", bytes}};
      if (sites.size() == 3) site.erase("line");
      *maxLine = std::max(*maxLine, source);
      sites.push_back(std::move(site));
      instruction += 3;
    }
    ++lineNo;
  }
  return sites;
}

// Draws of one pass, weights 1..n of the pass's read and written bytes, and
// the materials they sum to (draw d uses "material_<d % 5>").
inline void addDraws(nlohmann::json& pass, const SiteOptions& options) {
  double read = 0, written = 0, count = 0;
  for (const auto& line : pass["resources"]) {
    (line["access"] == "read" ? read : written) += double(line["bytes"]);
    count += double(line["count"]);
  }
  int n = options.drawsPerPass;
  double weights = n * (n + 1) / 2.0;
  nlohmann::json draws = nlohmann::json::array();
  std::map<std::string, nlohmann::json> materials;
  for (int d = 0; d < n; ++d) {
    double w = (d + 1) / weights;
    std::string material = "material_" + std::to_string(d % 5);
    nlohmann::json draw = {{"index", d}, {"name", "mesh " + std::to_string(d) + " · " + material}, {"mesh", std::to_string(d)},
                           {"material", material}, {"count", count * w}, {"bytes_read", read * w},
                           {"bytes_written", written * w}, {"bytes", read * w + written * w}};
    auto& m = materials[material];
    if (m.is_null()) m = {{"material", material}, {"draws", 0}, {"bytes_read", 0.0}, {"bytes_written", 0.0}, {"bytes", 0.0}};
    m["draws"] = int(m["draws"]) + 1;
    for (const char* key : {"bytes_read", "bytes_written", "bytes"}) m[key] = double(m[key]) + double(draw[key]);
    draws.push_back(std::move(draw));
  }
  std::stable_sort(draws.begin(), draws.end(), [](const auto& a, const auto& b) { return double(a["bytes"]) > double(b["bytes"]); });
  if (options.foldDraws && draws.size() > 256) {
    nlohmann::json rest = {{"draws", 0}, {"count", 0.0}, {"bytes_read", 0.0}, {"bytes_written", 0.0}, {"bytes", 0.0}};
    for (size_t d = 256; d < draws.size(); ++d) {
      rest["draws"] = int(rest["draws"]) + 1;
      for (const char* key : {"count", "bytes_read", "bytes_written", "bytes"}) rest[key] = double(rest[key]) + double(draws[d][key]);
    }
    draws.erase(draws.begin() + 256, draws.end());
    pass["draws_rest"] = rest;
  }
  pass["draws"] = std::move(draws);
  nlohmann::json list = nlohmann::json::array();
  for (auto& [name, m] : materials) list.push_back(m);
  std::stable_sort(list.begin(), list.end(), [](const auto& a, const auto& b) { return double(a["bytes"]) > double(b["bytes"]); });
  pass["materials"] = std::move(list);
}

// The result with sites, draws and materials on every pass of every sample,
// and each run's shader sources.
inline nlohmann::json withSites(nlohmann::json result, const SiteOptions& options = {}) {
  for (auto& run : result["runs"]) {
    std::map<std::string, int> lines;  // shader -> its highest line
    for (auto& sample : run["samples"]) {
      for (auto& pass : sample["passes"]) {
        int maxLine = 3;
        pass["sites"] = fixtureSites(pass, options, &maxLine);
        addDraws(pass, options);
        int& most = lines[fixtureShader(pass["name"])];
        most = std::max(most, maxLine);
      }
    }
    nlohmann::json sources = nlohmann::json::object();
    for (const auto& [shader, most] : lines) sources[shader] = fixtureSource(shader, most);
    run["shader_sources"] = sources;
  }
  return result;
}

}  // namespace tally::store::testing
