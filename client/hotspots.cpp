// tally hotspots: the sample's sites (by source line), draws or materials,
// fetched page by page, then per pass the heaviest rows, the rest and the
// bytes no row accounts for (lines without sites, such as derived depth
// writes, or work outside any draw), each with its share of the pass.
#include "hotspots.hpp"

#include <algorithm>
#include <map>

#include "command_support.hpp"
#include "tables.hpp"

namespace tally::client {
namespace {

using Align = Table::Align;

constexpr int kPageRows = 1000;  // the server's most per page

std::string number(const json& j, const char* key) { return j.contains(key) && j[key].is_number() ? fixedOrSci(j[key].get<double>()) : kMissing; }

double bytesOf(const json& row) { return row.value("bytes", 0.0); }

// "forward.frag.glsl:42", or "forward.frag.glsl %123" for a site without a line.
std::string lineLabel(const json& row) {
  std::string shader = row.value("shader", "");
  if (row.contains("line") && row["line"].is_number_integer()) return shader + ":" + std::to_string(row["line"].get<int64_t>());
  if (row.contains("instruction") && row["instruction"].is_number_integer()) {
    return shader + " %" + std::to_string(row["instruction"].get<int64_t>());
  }
  return shader + " " + row.value("disassembly", std::string("(no line)"));
}

std::string label(const json& row, const std::string& by) {
  if (by == "line") return lineLabel(row);
  if (by == "material") return row.value("material", "");
  return "#" + std::to_string(row.value("index", int64_t{0})) + " " + row.value("name", "");
}

// The rows, the passes and the rest of every page (the query's own page fields dropped).
Result<json> allRows(ApiClient& api, const std::string& sample, const HotspotsArgs& args) {
  std::string what = args.by == "line" ? "sites" : "draws";
  std::string list = args.by == "line" ? "sites" : args.by == "draw" ? "draws" : "materials";
  json out = {{"rows", json::array()}};
  for (int64_t offset = 0;;) {
    auto page = api.sampleRows(sample, what,
                               {{"by", args.by}, {"pass", args.pass}, {"limit", std::to_string(kPageRows)},
                                {"offset", std::to_string(offset)}});
    if (!page) return page;
    for (auto& row : (*page)[list]) out["rows"].push_back(std::move(row));
    out["passes"] = (*page)["passes"];
    out["rest"] = page->contains("rest") ? (*page)["rest"] : json::array();
    if (!(*page)["next_offset"].is_number_integer()) return out;
    offset = (*page)["next_offset"].get<int64_t>();
  }
}

// Per pass (frame order): the top rows with shares, the rest, what no row covers.
json hotspots(const json& all, const HotspotsArgs& args) {
  std::map<int64_t, std::vector<json>> byPass;
  for (const auto& row : all["rows"]) byPass[row.value("pass_position", int64_t{0})].push_back(row);
  std::map<int64_t, json> serverRest;
  for (const auto& rest : all["rest"]) serverRest[rest.value("pass_position", int64_t{0})] = rest;
  json passes = json::array();
  for (const auto& pass : all["passes"]) {
    int64_t position = pass.value("position", int64_t{0});
    auto found = byPass.find(position);
    if (found == byPass.end()) continue;
    std::vector<json>& rows = found->second;
    std::stable_sort(rows.begin(), rows.end(), [](const json& a, const json& b) { return bytesOf(a) > bytesOf(b); });
    double total = pass.value("bytes", 0.0), covered = 0, restBytes = 0;
    auto share = [total](double bytes) { return total > 0 ? json(bytes / total) : json(nullptr); };
    json top = json::array();
    int64_t restRows = 0;
    for (size_t i = 0; i < rows.size(); ++i) {
      covered += bytesOf(rows[i]);
      if (static_cast<int>(i) < args.top) {
        json row = {{"label", label(rows[i], args.by)}, {"bytes", bytesOf(rows[i])}, {"share", share(bytesOf(rows[i]))},
                    {"detail", rows[i]}};
        top.push_back(std::move(row));
      } else {
        restBytes += bytesOf(rows[i]);
        ++restRows;
      }
    }
    // The draws the server summed beyond the 256 it keeps (materials already include them).
    if (auto rest = serverRest.find(position); args.by == "draw" && rest != serverRest.end()) {
      restBytes += bytesOf(rest->second);
      covered += bytesOf(rest->second);
      restRows += rest->second.value("draws", int64_t{0});
    }
    double outside = std::max(0.0, total - covered);
    passes.push_back({{"pass", pass["name"]},
                      {"position", position},
                      {"bytes", total},
                      {"top", top},
                      {"rest", {{"rows", restRows}, {"bytes", restBytes}, {"share", share(restBytes)}}},
                      {"outside", {{"bytes", outside}, {"share", share(outside)}}}});
  }
  return passes;
}

void printPass(Io& io, const json& pass, const HotspotsArgs& args) {
  const char* noun = args.by == "line" ? "lines" : args.by == "draw" ? "draws" : "materials";
  io.out << "pass " << pass["pass"].get<std::string>() << ": " << humanBytes(pass["bytes"].get<double>()) << "/frame\n";
  std::string what = args.by == "line" ? "LINE" : args.by == "draw" ? "DRAW" : "MATERIAL";
  std::string count = args.by == "material" ? "DRAWS" : "COUNT";
  Table t({{"RANK", Align::Right}, {"BYTES/FRAME", Align::Right}, {"SHARE", Align::Right}, {count, Align::Right},
           {what}, {args.by == "line" ? "RESOURCES" : "READ/WRITTEN"}});
  auto share = [](const json& j) { return j.is_number() ? std::optional<double>(j.get<double>()) : std::nullopt; };
  double shares = 0;
  int rank = 1;
  for (const auto& row : pass["top"]) {
    const json& d = row["detail"];
    std::string extra;
    if (args.by == "line") {
      for (const auto& r : d.value("resources", json::array())) extra += (extra.empty() ? "" : ", ") + r.get<std::string>();
    } else {
      extra = humanBytes(d.value("bytes_read", 0.0)) + " / " + humanBytes(d.value("bytes_written", 0.0));
    }
    t.addRow({std::to_string(rank++), humanBytes(row["bytes"].get<double>()), percent(share(row["share"])),
              args.by == "material" ? number(d, "draws") : number(d, "count"), row["label"], extra});
    shares += share(row["share"]).value_or(0);
  }
  const json& rest = pass["rest"];
  if (rest["rows"].get<int64_t>() > 0) {
    t.addRow({"", humanBytes(rest["bytes"].get<double>()), percent(share(rest["share"])), "",
              "rest (" + std::to_string(rest["rows"].get<int64_t>()) + " " + noun + ")"});
    shares += share(rest["share"]).value_or(0);
  }
  const json& outside = pass["outside"];
  if (outside["bytes"].get<double>() > 0) {
    t.addRow({"", humanBytes(outside["bytes"].get<double>()), percent(share(outside["share"])), "",
              args.by == "line" ? "(lines without sites)" : "(outside any draw)"});
    shares += share(outside["share"]).value_or(0);
  }
  bool measured = pass["bytes"].get<double>() > 0;
  t.addRow({"", humanBytes(pass["bytes"].get<double>()), measured ? percent(shares) : kMissing, "", "total"});
  t.print(io.out);
}

}  // namespace

int runHotspots(ApiClient& api, const HotspotsArgs& args, Io& io) {
  if (args.by != "line" && args.by != "draw" && args.by != "material") return fail(io, "--by: must be line, draw or material");
  if (args.top < 1) return fail(io, "--top: must be at least 1");
  auto samples = api.getRunSamples(args.run);
  if (!samples) return fail(io, samples.error());
  std::vector<std::string> ids;  // in camera order
  for (const auto& s : (*samples)["samples"]) ids.push_back(std::to_string(s.value("id", int64_t{0})));
  if (ids.empty()) return fail(io, "run " + args.run + " has no samples");
  std::string sample = args.sample.empty() ? ids.front() : args.sample;
  if (std::find(ids.begin(), ids.end(), sample) == ids.end()) {
    std::string list;
    for (const auto& id : ids) list += (list.empty() ? "" : ", ") + id;
    return fail(io, "sample " + sample + " is not a sample of run " + args.run + " (its samples: " + list + ")");
  }
  auto all = allRows(api, sample, args);
  if (!all) return fail(io, all.error());
  json passes = hotspots(*all, args);
  json out = {{"run", args.run}, {"sample", sample}, {"by", args.by}, {"top", args.top}, {"passes", passes}};
  if (io.json) {
    printJson(io, out);
    return 0;
  }
  if (passes.empty()) {
    return fail(io, "sample " + sample + " of run " + args.run + " has no " + (args.by == "line" ? "sites" : "draws") +
                        (args.pass.empty() ? "" : " in pass " + args.pass) +
                        " (capture with \"sites\": true, or the layer's --sites; docs/result-schema.md)");
  }
  io.out << "run " << args.run << ", sample " << sample << ": bytes per frame by " << args.by << "\n";
  for (const auto& pass : passes) {
    io.out << "\n";
    printPass(io, pass, args);
  }
  return 0;
}

}  // namespace tally::client
