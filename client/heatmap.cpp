// `tally heatmap`: GET /api/heatmap printed as a text grid, as the
// dashboard draws it (rows along z top to bottom, columns along x; a sphere's
// rows from north to south), with a summary underneath.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>

#include "commands.hpp"
#include "tables.hpp"

namespace tally::client {
namespace {

using nlohmann::json;

std::optional<double> numberAt(const json& j, const char* key) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_number()) return std::nullopt;
  return it->get<double>();
}

std::string valueText(const std::string& metric, std::optional<double> v) {
  if (!v) return kMissing;
  if (metric == "bytes") return humanBytes(*v);
  return fixed(v, 3) + " ms";
}

// A cell's text, 6 characters: the ratio (with * when significant) or the
// value; "." for an empty cell, "?" for one only one renderer measured.
std::string cellText(const json& cell, bool versus, const std::string& metric) {
  char buf[32];
  if (cell["value_a"].is_null()) return cell["empty"] == "incomplete" ? "?" : ".";
  if (versus) {
    if (!cell["ratio"].is_number()) return "?";
    bool significant = cell["significant"].is_boolean() && cell["significant"].get<bool>();
    std::snprintf(buf, sizeof buf, "%.2f%s", cell["ratio"].get<double>(), significant ? "*" : "");
    return buf;
  }
  double v = cell["value_a"].get<double>();
  if (metric == "bytes") {
    std::snprintf(buf, sizeof buf, "%.0fM", v / 1048576.0);  // MiB per frame
  } else {
    std::snprintf(buf, sizeof buf, "%.2f", v);
  }
  return buf;
}

std::string pad(const std::string& s, size_t width) {
  return s.size() >= width ? s : std::string(width - s.size(), ' ') + s;
}

// A significant cell of B against A: green where B is lower (better), red
// where higher; the rest uncoloured.
std::optional<Rgb> cellColour(const json& cell, bool versus) {
  if (!versus || !cell.is_object() || !cell["ratio"].is_number()) return std::nullopt;
  if (!cell["significant"].is_boolean() || !cell["significant"].get<bool>()) return std::nullopt;
  return changeColour(cell["ratio"].get<double>() - 1);
}

std::string where(const json& ref, const json& layout) {
  if (!ref.is_object()) return kMissing;
  int c = ref.value("column", 0), r = ref.value("row", 0);
  std::string text = "cell " + std::to_string(c) + "," + std::to_string(r);
  if (layout.value("layout", "") == "floor" && layout.contains("origin") && layout.contains("cell_size")) {
    double x = layout["origin"][0].get<double>() + (c + 0.5) * layout["cell_size"][0].get<double>();
    double z = layout["origin"][1].get<double>() + (r + 0.5) * layout["cell_size"][1].get<double>();
    char buf[64];
    std::snprintf(buf, sizeof buf, " (x %.1f, z %.1f)", x, z);
    text += buf;
  } else if (layout.value("layout", "") == "sphere") {
    char buf[64];
    std::snprintf(buf, sizeof buf, " (lat %.0f, lon %.0f)", layout["latitudes_deg"][r].get<double>(),
                  layout["longitudes_deg"][c].get<double>());
    text += buf;
  }
  return text;
}

}  // namespace

int runHeatmap(ApiClient& api, const HeatmapArgs& args, Io& io) {
  auto res = api.heatmap({{"capture", args.capture},
                          {"renderer", args.renderer},
                          {"versus", args.versus},
                          {"metric", args.metric},
                          {"yaw", args.yaw},
                          {"scene", args.scene},
                          {"width", args.width ? std::to_string(*args.width) : ""},
                          {"height", args.height ? std::to_string(*args.height) : ""},
                          {"counting", args.counting}});
  if (!res) {
    io.err << "tally: " << res.error() << '\n';
    return 1;
  }
  if (io.json) {
    io.out << res->dump(2) << '\n';
    return 0;
  }
  const json& body = *res;
  const json& layout = body["layout"];
  const bool versus = !body["versus"].is_null();
  const std::string metric = body.value("metric", args.metric);
  const bool floor = layout.value("layout", "") == "floor";
  io.out << "capture " << args.capture << ", " << body.value("scene", "") << " " << body.value("width", 0) << "x"
         << body.value("height", 0) << " on " << body.value("device", "") << ", " << layout.value("layout", "")
         << " layout " << layout.value("columns", 0) << "x" << layout.value("rows", 0) << ", "
         << (metric == "bytes" ? "bytes per frame" : "frame time") << ", yaw "
         << (body["yaw"].is_string() ? body["yaw"].get<std::string>() : body["yaw"].dump()) << "\n";
  if (versus) {
    const std::string b = body["versus"].get<std::string>(), a = body["renderer"].get<std::string>();
    io.out << "cells: " << io.colour.paint(b, labelColour(b)) << " / " << io.colour.paint(a, labelColour(a))
           << " (below 1: " << body["versus"].get<std::string>() << " lower); * the difference is significant"
           << (metric == "frame_ms" ? " (Mann-Whitney, 95% ratio interval excludes 1)" : " (counts differ)")
           << "\n";
  } else {
    io.out << "cells: " << body["renderer"].get<std::string>() << ", "
           << (metric == "bytes" ? "MiB per frame" : "ms per frame") << "\n";
  }
  io.out << "'.' no walkable floor (or not measured), '?' measured by one renderer only\n";
  if (floor) {
    io.out << "rows along z from " << layout["origin"][1].get<double>() << " (top), columns along x from "
           << layout["origin"][0].get<double>() << " (left); cell " << layout["cell_size"][0].get<double>() << " x "
           << layout["cell_size"][1].get<double>() << "\n";
  } else {
    io.out << "rows: latitude from north (top) to south, columns: longitude from -180 to 180\n";
  }
  io.out << "\n";
  const int columns = layout.value("columns", 0), rows = layout.value("rows", 0);
  const size_t width = 7;
  std::string header = "     ";
  for (int c = 0; c < columns; ++c) header += pad(std::to_string(c), width);
  io.out << header << "\n";
  const json& cells = body["cells"];
  for (int r = 0; r < rows; ++r) {
    std::string line = pad(std::to_string(r), 4) + " ";
    for (int c = 0; c < columns; ++c) {
      size_t k = size_t(r) * columns + c;
      const std::string text = k < cells.size() ? cellText(cells[k], versus, metric) : "?";
      line += pad("", width - std::min(width, text.size())) +
              io.colour.paint(text, k < cells.size() ? cellColour(cells[k], versus) : std::nullopt);
    }
    io.out << line << "\n";
  }
  const json& s = body["summary"];
  io.out << "\nSUMMARY\n";
  io.out << "cells measured: " << s.value("cells_measured", 0) << " of " << s.value("cells", 0) << " ("
         << s.value("cells_empty", 0) << " empty, " << s.value("cells_incomplete", 0) << " incomplete)\n";
  if (s.contains("a")) {
    io.out << body["renderer"].get<std::string>() << ": median " << valueText(metric, numberAt(s["a"], "median"))
           << ", lowest " << valueText(metric, numberAt(s["a"]["min"], "value")) << " at " << where(s["a"]["min"], layout)
           << ", highest " << valueText(metric, numberAt(s["a"]["max"], "value")) << " at "
           << where(s["a"]["max"], layout) << "\n";
  }
  if (versus && s["ratio"].is_object()) {
    const std::string b = body["versus"].get<std::string>(), a = body["renderer"].get<std::string>();
    const json& ratio = s["ratio"];
    auto pct = [](double r) {
      char buf[32];
      std::snprintf(buf, sizeof buf, "%+.1f%%", (r - 1.0) * 100.0);
      return std::string(buf);
    };
    io.out << b << " / " << a << ": median " << fixed(numberAt(ratio, "median"), 3) << ", geometric mean "
           << fixed(numberAt(ratio, "geometric_mean"), 3) << "\n";
    io.out << "  best for " << b << " (lowest ratio) at " << where(ratio["min"], layout) << ": "
           << fixed(numberAt(ratio["min"], "value"), 3) << " (" << pct(ratio["min"]["value"].get<double>()) << ")\n";
    io.out << "  worst for " << b << " (highest ratio) at " << where(ratio["max"], layout) << ": "
           << fixed(numberAt(ratio["max"], "value"), 3) << " (" << pct(ratio["max"]["value"].get<double>()) << ")\n";
    io.out << "significant cells: " << s.value("significant", 0) << " of " << s.value("cells_measured", 0) << " ("
           << b << " lower in " << s.value("b_lower", 0) << ", higher in " << s.value("b_higher", 0) << ")\n";
    if (s["b_best_significant"].is_object()) {
      io.out << "  best significant win for " << b << ": " << where(s["b_best_significant"], layout) << ", ratio "
             << fixed(numberAt(s["b_best_significant"], "value"), 3) << "\n";
    } else {
      io.out << "  " << b << " is significantly lower in no cell\n";
    }
  }
  return 0;
}

}  // namespace tally::client
