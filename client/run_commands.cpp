// tally runs, show, compare, crossover: stored runs and what is computed from them.
#include "commands.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "command_support.hpp"
#include "tables.hpp"

namespace tally::client {

namespace {

using Align = Table::Align;

}  // namespace

int runRuns(ApiClient& api, const RunsArgs& args, Io& io) {
  auto res = args.all ? api.listAllRuns(args.filters, args.limit) : api.listRuns(args.filters, args.limit);
  // A page with footprint runs says which bytes are which: requested beside footprint.
  // A page of runs from named hosts (a fleet) says which host made each.
  bool footprint = false, hosts = false, labels = false;
  if (res) {
    for (const auto& run : runList(*res)) {
      RunView r = runView(run);
      footprint = footprint || r.hasFootprint();
      hosts = hosts || !r.host.empty();
      labels = labels || !r.labels.empty();
    }
  }
  std::vector<Table::Column> columns = {{"ID", Align::Right},
                                        {"CAPTURE", Align::Right},
                                        {"RENDERER"},
                                        {"SCENE"},
                                        {"SIZE", Align::Right},
                                        {"DEVICE"},
                                        {"SAMPLES", Align::Right},
                                        {"FRAME MS", Align::Right},
                                        {footprint ? "REQUESTED/FRAME" : "BYTES/FRAME", Align::Right}};
  constexpr size_t kHostColumn = 6;  // after DEVICE
  if (hosts) columns.insert(columns.begin() + kHostColumn, {"HOST"});
  if (footprint) {
    columns.push_back({"FOOTPRINT/FRAME", Align::Right});
    columns.push_back({"REUSE", Align::Right});
  }
  if (labels) columns.push_back({"LABELS"});
  return printListing(io, res, args.all, "runs", columns, [footprint, hosts, labels](const json& page, Table& t) {
    for (const auto& run : runList(page)) {
      RunView r = runView(run);
      std::vector<std::string> row = {r.id, orMissing(r.capture), r.variant, r.scene, size(r), orMissing(r.device),
                                      r.samples ? std::to_string(*r.samples) : kMissing, fixed(r.frameMs, 3),
                                      humanBytes(r.bytes)};
      if (hosts) row.insert(row.begin() + kHostColumn, orMissing(r.host));
      if (footprint) {
        row.push_back(humanBytes(r.footprintBytes));
        row.push_back(ratio(r.reuse));
      }
      if (labels) row.push_back(orMissing(r.labels));
      Table::Paints paints(row.size());
      paints[2] = labelColour(r.variant);  // RENDERER, before HOST may be inserted
      t.addRow(row, paints);
    }
  });
}

namespace {

// The run's identity, device, ceilings and notes, above its samples.
void printRunHeader(Io& io, const json& run, const RunView& r) {
  io.out << "run " << r.id << ": " << io.colour.paint(r.variant, labelColour(r.variant)) << " on " << r.scene
         << " at " << size(r) << '\n';
  if (!r.options.empty()) {
    io.out << "options:";
    for (const auto& [key, value] : r.options.items()) {
      io.out << ' ' << key << '=' << (value.is_string() ? value.get<std::string>() : value.dump());
    }
    io.out << '\n';
  }
  io.out << "device: " << orMissing(r.device);
  if (!r.host.empty()) io.out << "   host: " << r.host;
  io.out << "   capture: " << orMissing(r.capture);
  if (!r.counting.empty()) io.out << "   counting: " << r.counting;
  if (r.footprintBlockBytes) io.out << "   footprint: " << *r.footprintBlockBytes << "-byte blocks";
  if (r.lights) io.out << "   lights: " << *r.lights;
  if (r.renderTargetBytes)
    io.out << "   render targets: " << humanBytes(static_cast<double>(*r.renderTargetBytes));
  if (!r.tallyVersion.empty() || !r.tallyCommit.empty())
    io.out << "   built by: tally " << orMissing(r.tallyVersion) << " (commit " << orMissing(r.tallyCommit) << ")";
  io.out << "\n";
  // The device's ceilings measured by the run's capture (the roofline's).
  if (run.contains("ceilings") && run["ceilings"].is_object()) {
    const json& c = run["ceilings"];
    auto rate = [](const json& v, const char* unit) {
      if (!v.is_number()) return std::string(kMissing);
      double x = v.get<double>();
      const char* prefix = x >= 1e12 ? "T" : x >= 1e9 ? "G" : x >= 1e6 ? "M" : "";
      double scale = x >= 1e12 ? 1e12 : x >= 1e9 ? 1e9 : x >= 1e6 ? 1e6 : 1;
      return fixed(x / scale, 1) + " " + prefix + unit;
    };
    io.out << "ceilings: bandwidth " << rate(c.value("bandwidth_bytes_per_s", json()), "B/s") << "   arithmetic "
           << rate(c.value("arithmetic_ops_per_s", json()), "op/s");
    if (c.contains("copy_bytes") && c["copy_bytes"].is_number())
      io.out << "   (copy of " << humanBytes(c["copy_bytes"].get<double>()) << ")";
    io.out << "\n";
  }
  // What the scene's loader simplified or ignored, then the renderer's choices.
  const json notes = run.contains("notes") && run["notes"].is_object() ? run["notes"] : json::object();
  auto text = [](const json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); };
  if (notes.contains("scene") && notes["scene"].is_array()) {
    for (const auto& note : notes["scene"]) io.out << "scene note: " << text(note) << '\n';
  }
  // An application captured under the Vulkan layer: the layer's notes, and
  // the shaders it left uninstrumented (docs/layer.md).
  if (notes.contains("layer_notes") && notes["layer_notes"].is_array()) {
    for (const auto& note : notes["layer_notes"]) io.out << "layer note: " << text(note) << '\n';
  }
  if (notes.contains("uninstrumented_shaders") && notes["uninstrumented_shaders"].is_array()) {
    for (const auto& s : notes["uninstrumented_shaders"]) {
      if (!s.is_object()) continue;
      io.out << "uninstrumented shader: " << text(s.value("name", json(""))) << " (" << text(s.value("stage", json("")))
             << "): " << text(s.value("reason", json(""))) << '\n';
    }
  }
  for (const auto& [key, value] : notes.items()) {
    if (key != "scene" && key != "layer_notes" && key != "uninstrumented_shaders") {
      io.out << "note: " << key << " = " << text(value) << '\n';
    }
  }
  io.out << '\n';
}

// One row per sample, then per line where the run measured footprints.
int printSampleTable(ApiClient& api, Io& io, const json& run, const RunView& r, const json& samples) {
  // A variant's error against its reference variant gets a column where any sample has one.
  bool variantErrors = false;
  // Footprint: requested bytes beside the footprint and reuse, where any sample has one.
  bool footprint = r.hasFootprint();
  for (const auto& sample : sampleList(samples)) {
    SampleView s = sampleView(sample);
    variantErrors = variantErrors || s.hasVariantError;
    footprint = footprint || s.footprintBytes.has_value();
  }
  const json notes = run.contains("notes") && run["notes"].is_object() ? run["notes"] : json::object();
  // An application's samples are its frames (docs/layer.md): no cameras.
  const bool application = notes.contains("source") && notes["source"].is_object() &&
                           (notes["source"].value("kind", json("")) == "application" ||
                            notes["source"].value("kind", json("")) == "replay");
  std::vector<Table::Column> columns = {{application ? "FRAME" : "CAMERA"},
                                        {"SKY", Align::Right},
                                        {"FRAME MS", Align::Right},
                                        {"OVERHEAD", Align::Right},
                                        {"IMAGE ERROR", Align::Right}};
  if (variantErrors) columns.push_back({"VARIANT ERROR", Align::Right});
  columns.push_back({footprint ? "REQUESTED READ/FRAME" : "READ/FRAME", Align::Right});
  columns.push_back({footprint ? "REQUESTED WRITTEN/FRAME" : "WRITTEN/FRAME", Align::Right});
  if (footprint) {
    columns.push_back({"FOOTPRINT/FRAME", Align::Right});
    columns.push_back({"REUSE", Align::Right});
  }
  Table t(columns);
  for (const auto& sample : sampleList(samples)) {
    SampleView s = sampleView(sample);
    std::optional<double> read = s.bytesRead, written = s.bytesWritten;
    if ((!read || !written) && !s.id.empty()) {
      // The sample list carries totals only; the split comes from the sample's counters.
      auto full = api.getSample(s.id);
      if (!full) return fail(io, full.error());
      auto [r2, w2] = sampleReadWrite(*full);
      read = r2;
      written = w2;
    }
    std::string image = s.identical ? "identical" : s.psnr ? fixed(s.psnr, 1) + " dB" : kMissing;
    if (!s.against.empty() && image != kMissing) image += " vs " + s.against;
    std::vector<std::string> row = {orMissing(s.camera), percent(s.skyFraction), fixed(s.frameMs, 3),
                                    ratio(s.overhead), image};
    if (variantErrors) {
      std::string variant = !s.hasVariantError ? kMissing
                            : s.variantIdentical ? "identical"
                            : s.variantPsnr      ? fixed(s.variantPsnr, 1) + " dB"
                                                 : kMissing;
      if (s.hasVariantError && variant != kMissing) variant += " vs " + s.variantAgainst;
      row.push_back(variant);
    }
    Table::Paints paints(row.size());
    row.push_back(humanBytes(read));
    paints.push_back(readColour());
    row.push_back(humanBytes(written));
    paints.push_back(writtenColour());
    if (footprint) {
      row.push_back(humanBytes(s.footprintBytes));
      row.push_back(ratio(s.reuse));
    }
    t.addRow(row, paints);
  }
  t.print(io.out, io.colour);
  if (footprint) {
    // Per line, averaged over the samples: what each pass asked for against
    // the distinct bytes it touched.
    io.out << '\n';
    Table lines({{"PASS"},
                 {"RESOURCE"},
                 {"ACCESS"},
                 {"REQUESTED/FRAME", Align::Right},
                 {"FOOTPRINT/FRAME", Align::Right},
                 {"REUSE", Align::Right}});
    for (const auto& l : runLines(run)) {
      lines.addRow(
          {l.pass, l.resource, l.access, humanBytes(l.bytes), humanBytes(l.footprintBytes), ratio(l.reuse)},
          {std::nullopt, std::nullopt, accessColour(l.access)});
    }
    lines.print(io.out, io.colour);
  }
  return 0;
}

}  // namespace

int runShow(ApiClient& api, const std::string& runId, Io& io) {
  auto run = api.getRun(runId);
  if (!run) return fail(io, run.error());
  auto samples = api.getRunSamples(runId);
  if (!samples) return fail(io, samples.error());
  if (io.json) {
    printJson(io, json{{"run", *run}, {"samples", *samples}});
    return 0;
  }
  RunView r = runView(*run);
  printRunHeader(io, *run, r);
  return printSampleTable(api, io, *run, r, *samples);
}

namespace {

// "1.12x [1.08x, 1.17x]"; an unbounded end is "-".
std::string ratio3(double v) { return fixed(v, 3) + "x"; }

std::string intervalText(const json& interval) {
  auto end = [](const json& v) { return v.is_number() ? ratio3(v.get<double>()) : kMissing; };
  return "[" + end(interval.value("lower", json())) + ", " + end(interval.value("upper", json())) + "]";
}

std::string pText(double p) { return p < 1e-4 ? "<0.0001" : fixed(p, 4); }

// Each later run against the first: one row per figure (frame, then passes),
// then the counts.
// variants: each run's, for its colour.
void printSignificance(const json& comparison, const std::vector<std::string>& names,
                       const std::vector<std::string>& variants, Io& io) {
  const json& list = comparison.value("significance", json::array());
  if (!list.is_array() || list.empty()) return;
  double confidence = comparison.value("confidence", 0.95);
  const json& first = list.front().value("frame", json());
  bool aligned = !first.is_object() || first.value("strata", "cameras") == "cameras";
  io.out << "\nSignificance against " << names[0] << " (" << fixed(confidence * 100, 0) << "% intervals over frames"
         << (aligned ? ", each camera's aligned on its median" : " pooled over cameras") << "; docs/statistics.md):\n";
  Table t({{"RUN"},
           {"FIGURE"},
           {"RATIO", Align::Right},
           {"INTERVAL", Align::Right},
           {"P", Align::Right},
           {"CLIFF", Align::Right},
           {"VERDICT"},
           {"NOTE"}});
  std::vector<std::string> countLines;
  for (size_t i = 0; i < list.size(); ++i) {
    const json& s = list[i];
    std::string run = i + 1 < names.size() ? names[i + 1] : "#" + std::to_string(s.value("run_b", 0));
    std::optional<Rgb> runPaint;
    if (i + 1 < variants.size()) runPaint = labelColour(variants[i + 1]);
    if (s.contains("error")) {
      countLines.push_back(run + ": " + s.value("error", ""));
      continue;
    }
    auto row = [&](const std::string& figure, const json& c) {
      const json& interval = c.value("interval", json::object());
      double widening = interval.value("widening", json(1.0)).is_number() ? interval.value("widening", 1.0) : 1.0;
      std::string note = c.value("verdict", "") == "same" ? c.value("reason", "") : "";
      if (widening > 1.0) {
        std::string across = "widened " + fixed(widening, 1) + "x by repeated captures";
        note = note.empty() ? across : note + "; " + across;
      }
      const std::string verdict = c.value("verdict", "");
      t.addRow({run, figure, ratio3(c.value("ratio", 1.0)), intervalText(interval),
                pText(c.value("mann_whitney", json::object()).value("p", 1.0)),
                signedFixed(c.value("cliffs_delta", json::object()).value("delta", 0.0), 2), verdict, note},
               {runPaint, std::nullopt, verdictColour(verdict), std::nullopt, std::nullopt, std::nullopt,
                verdictColour(verdict)});
    };
    if (s.value("frame", json()).is_object()) {
      row("(frame)", s["frame"]);
    } else {
      t.addRow(
          {run, "(frame)", kMissing, kMissing, kMissing, kMissing, kMissing, s.value("frame_missing", "")},
          {runPaint});
    }
    for (const auto& p : s.value("passes", json::array())) row(p.value("pass", ""), p);
    for (const auto& p : s.value("passes_missing", json::array())) {
      t.addRow({run, p.value("pass", ""), kMissing, kMissing, kMissing, kMissing, kMissing, p.value("reason", "")});
    }
    const json& counts = s.value("counts", json::object());
    const json& changes = counts.value("changes", json::array());
    std::string line = run + ": counts " + counts.value("verdict", "") + " (" + std::to_string(changes.size()) +
                       " of " + std::to_string(counts.value("lines", 0)) +
                       " lines differ, compared exactly; per frame, summed over the " +
                       std::to_string(s.value("cameras", 0)) + " shared cameras)";
    countLines.push_back(line);
    size_t shown = 0;
    for (const auto& c : changes) {
      if (++shown > 10) {
        countLines.push_back("  ... and " + std::to_string(changes.size() - 10) + " more (--json lists them)");
        break;
      }
      bool bytes = c.value("line", "") == "total";
      double a = c.value("a", 0.0), b = c.value("b", 0.0);
      countLines.push_back("  " + c.value("line", "") + ": " + (bytes ? humanBytes(a) : fixed(a, 0)) + " -> " +
                           (bytes ? humanBytes(b) : fixed(b, 0)));
    }
  }
  t.print(io.out, io.colour);
  for (const auto& l : countLines) io.out << l << '\n';
}

}  // namespace

int runCompare(ApiClient& api, const CompareArgs& args, Io& io) {
  const std::vector<std::string>& runIds = args.runs;
  auto res = api.compare(runIds, args.confidence, args.threshold, !args.framesOnly, !args.pooled);
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  CompareView c = compareView(*res);
  std::vector<std::string> names;
  for (size_t i = 0; i < runIds.size(); ++i) {
    std::string id = i < c.runs.size() && !c.runs[i].id.empty() ? c.runs[i].id : runIds[i];
    names.push_back("#" + id);
    if (i < c.runs.size()) {
      const RunView& r = c.runs[i];
      io.out << "#" << id << ": " << io.colour.paint(r.variant, labelColour(r.variant)) << " " << r.scene
             << " " << size(r) << " on " << orMissing(r.device) << '\n';
    }
  }
  io.out << '\n';
  std::vector<Table::Column> columns = {{"PASS"}, {"RESOURCE"}, {"METRIC"}};
  for (const auto& n : names) columns.push_back({n, Align::Right});
  for (size_t i = 1; i < names.size(); ++i) {
    columns.push_back({"delta" + names[i], Align::Right});
    columns.push_back({"ratio" + names[i], Align::Right});
  }
  Table t(columns);
  for (const auto& row : c.rows) {
    bool bytes = row.metric == "bytes" || row.metric == "requested" || row.metric == "footprint";
    auto value = [&](std::optional<double> v) {
      if (bytes) return humanBytes(v);
      if (row.metric == "ms") return fixed(v, 3);
      if (row.metric == "reuse") return ratio(v);
      return fixed(v, 0);
    };
    auto delta = [&](std::optional<double> v) {
      if (bytes) return signedBytes(v);
      return signedFixed(v, row.metric == "ms" ? 3 : row.metric == "reuse" ? 2 : 0);
    };
    std::vector<std::string> cells = {row.pass, row.resource, row.metric};
    Table::Paints paints = {std::nullopt, accessColour(row.access), std::nullopt};
    for (size_t i = 0; i < names.size(); ++i)
      cells.push_back(value(i < row.values.size() ? row.values[i].value : std::nullopt));
    paints.resize(cells.size());
    // Red for worse, green for better, as the dashboard: lower is better but for reuse.
    for (size_t i = 1; i < names.size(); ++i) {
      bool has = i < row.values.size();
      auto change = changeColour(has ? row.values[i].delta : std::nullopt, row.metric == "reuse");
      cells.push_back(delta(has ? row.values[i].delta : std::nullopt));
      cells.push_back(ratio(has ? row.values[i].ratio : std::nullopt));
      paints.insert(paints.end(), {change, change});
    }
    t.addRow(cells, paints);
  }
  t.print(io.out, io.colour);
  std::vector<std::string> variants;
  for (const auto& r : c.runs) variants.push_back(r.variant);
  printSignificance(*res, names, variants, io);
  return 0;
}

namespace {

// Numbers of a crossover answer, which may be null.
std::optional<double> num(const json& j, const std::string& key) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return std::nullopt;
  return it->get<double>();
}

std::string str(const json& j, const std::string& key) {
  auto it = j.find(key);
  return it != j.end() && it->is_string() ? it->get<std::string>() : std::string();
}

// "1193x671"; kMissing for null.
std::string resolutionText(const json& r) {
  if (!r.is_object()) return kMissing;
  return std::to_string(r.value("width", 0)) + "x" + std::to_string(r.value("height", 0));
}

// A value of the metric: bytes (binary units) or milliseconds.
std::string metricText(const std::string& metric, std::optional<double> v) {
  if (!v) return kMissing;
  if (metric == "bytes") return humanBytes(*v);
  return fixed(v, 3) + " ms";
}

// A cost per pixel, shown per megapixel.
std::string perPixelText(const std::string& metric, std::optional<double> b) {
  if (!b) return kMissing;
  return metricText(metric, *b * 1e6) + "/Mpx";
}

std::string intervalText(const json& ci, const std::function<std::string(std::optional<double>)>& format) {
  if (!ci.is_array() || ci.size() != 2) return kMissing;
  return format(ci[0].get<double>()) + " .. " + format(ci[1].get<double>());
}

std::string pixelsText(std::optional<double> p) {
  if (!p) return kMissing;
  return fixed(*p, 0);
}

}  // namespace

int runCrossover(ApiClient& api, const CrossoverArgs& args, Io& io) {
  auto res = api.crossover(args.capture, args.metric);
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  const json& body = *res;
  const std::string metric = str(body, "metric").empty() ? args.metric : str(body, "metric");
  const int level = static_cast<int>(std::lround(num(body, "confidence").value_or(0.95) * 100));
  const std::string ci = std::to_string(level) + "% CI";
  io.out << "capture " << args.capture << ", " << (metric == "bytes" ? "bytes per frame" : "frame time (ms)")
         << " against pixels: y = a + b * pixels, least squares, " << level << "% t intervals; poor fit: R2 < "
         << fixedOrSci(num(body, "poor_fit_r2").value_or(0.9)) << "\n\n";
  const json series = body.value("series", json::array());
  if (series.empty()) {
    io.out << "no runs in this capture\n";
    return 0;
  }
  auto metricFormat = [&](std::optional<double> v) { return metricText(metric, v); };
  auto perPixelFormat = [&](std::optional<double> v) { return perPixelText(metric, v); };
  Table fits({{"VARIANT"}, {"SCENE"}, {"N", Align::Right}, {"A (FIXED)", Align::Right}, {"A " + ci, Align::Right},
              {"B (PER PIXEL)", Align::Right}, {"B " + ci, Align::Right}, {"R2", Align::Right}, {"FIT"}});
  Table residuals({{"VARIANT"}, {"SCENE"}, {"RESOLUTION"}, {"PIXELS", Align::Right}, {"VALUE", Align::Right},
                   {"RESIDUAL", Align::Right}, {"RUN", Align::Right}});
  for (const auto& s : series) {
    const json& fit = s.contains("fit") ? s["fit"] : json(nullptr);
    const Table::Paints variant = {labelColour(str(s, "variant"))};
    if (!fit.is_object()) {
      fits.addRow({str(s, "variant"), str(s, "scene"), kMissing, kMissing, kMissing, kMissing, kMissing,
                   kMissing, "none: " + orMissing(str(s, "error"))},
                  variant);
      continue;
    }
    fits.addRow({str(s, "variant"), str(s, "scene"), std::to_string(fit.value("n", 0)),
                 metricFormat(num(fit, "a")), intervalText(fit["a_ci"], metricFormat),
                 perPixelFormat(num(fit, "b")), intervalText(fit["b_ci"], perPixelFormat),
                 fixed(num(fit, "r2"), 4), fit.value("poor_fit", false) ? "POOR (not linear)" : "ok"},
                variant);
    for (const auto& p : fit.value("points", json::array())) {
      std::string resolution = p.contains("width") ? std::to_string(p.value("width", 0)) + "x" +
                                                         std::to_string(p.value("height", 0))
                                                   : kMissing;
      residuals.addRow({str(s, "variant"), str(s, "scene"), resolution, pixelsText(num(p, "pixels")),
                        metricFormat(num(p, "value")), metricFormat(num(p, "residual")),
                        p.contains("run") ? "#" + std::to_string(p.value("run", 0)) : kMissing},
                       variant);
    }
  }
  io.out << "FITS\n";
  fits.print(io.out, io.colour);
  if (residuals.rows() > 0) {
    io.out << "\nRESIDUALS (value - fitted)\n";
    residuals.print(io.out, io.colour);
  }
  const json crossings = body.value("crossings", json::array());
  io.out << "\nCROSSINGS (pixels* = (a2 - a1) / (b1 - b2), Fieller " << ci << ")\n";
  if (crossings.empty()) {
    io.out << "none: no two variants with a fit on the same scene and device\n";
    return 0;
  }
  Table t({{"FIRST"}, {"SECOND"}, {"SCENE"}, {"RESULT"}, {"PIXELS", Align::Right}, {"PIXELS " + ci, Align::Right},
           {"16:9"}, {"16:9 " + ci}, {"LOWER"}});
  for (const auto& c : crossings) {
    std::string kind = str(c, "kind");
    std::string lower;
    if (kind == "crosses") {
      lower = str(c, "lower_below") + " below, " + str(c, "lower_above") + " above";
    } else if (kind == "no_significant_crossing") {
      lower = kMissing;
    } else {
      lower = str(c, "lower_throughout") + " throughout";
    }
    std::string result = kind == "crosses"         ? "crosses"
                         : kind == "outside_range" ? "no crossing in range"
                         : kind == "parallel"      ? "parallel within error"
                         : kind == "no_significant_crossing" ? "no significant crossing"
                                                             : kind;
    std::string resCi = kMissing;
    if (c.contains("resolution_ci") && c["resolution_ci"].is_array() && c["resolution_ci"].size() == 2) {
      resCi = resolutionText(c["resolution_ci"][0]) + " .. " + resolutionText(c["resolution_ci"][1]);
    }
    t.addRow({str(c, "first"), str(c, "second"), str(c, "scene"), result, pixelsText(num(c, "pixels")),
              intervalText(c.contains("pixels_ci") ? c["pixels_ci"] : json(nullptr), pixelsText),
              resolutionText(c.contains("resolution") ? c["resolution"] : json(nullptr)), resCi, lower},
             {labelColour(str(c, "first")), labelColour(str(c, "second"))});
  }
  t.print(io.out, io.colour);
  return 0;
}

}  // namespace tally::client
