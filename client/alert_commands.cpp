// tally baseline, alerts: baselines and the alerts raised against them.
#include "commands.hpp"

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

// ---- baselines and alerts -------------------------------------------------------

namespace {

std::string numberCell(const json& j, const char* key, int digits) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return kMissing;
  return fixed(std::optional<double>(j[key].get<double>()), digits);
}

std::string labelsCell(const json& labels) {
  std::string out;
  if (!labels.is_object()) return kMissing;
  for (const auto& [k, v] : labels.items()) out += (out.empty() ? "" : ",") + k + "=" + (v.is_string() ? v.get<std::string>() : v.dump());
  return orMissing(out);
}

std::string configurationCell(const json& b) {
  const json c = b.value("configuration", json::object());
  return c.value("variant", "") + " " + c.value("scene", "") + " " + std::to_string(c.value("width", 0)) + "x" +
         std::to_string(c.value("height", 0)) + " " + c.value("device", "") + " " + c.value("counting", "");
}

void addBaselineRow(Table& t, const json& b) {
  t.addRow({idString(b.value("id", json())), idString(b.value("run", json())), b.value("name", json()).is_string() ? b["name"].get<std::string>() : kMissing,
            configurationCell(b), numberCell(b, "threshold", 3), b.value("status", ""), labelsCell(b.value("labels", json())),
            idString(b.value("open_alerts", json(0)))});
}

std::vector<Table::Column> baselineColumns() {
  return {{"ID", Align::Right}, {"RUN", Align::Right}, {"NAME"}, {"CONFIGURATION"}, {"THRESHOLD", Align::Right},
          {"STATUS"}, {"LABELS"}, {"OPEN ALERTS", Align::Right}};
}

}  // namespace

int runBaselineSet(ApiClient& api, const BaselineSetArgs& args, Io& io) {
  auto res = api.setBaseline(args.run, args.threshold, args.name);
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  Table t(baselineColumns());
  addBaselineRow(t, *res);
  t.print(io.out);
  if (res->contains("replaced") && (*res)["replaced"].is_number()) {
    io.err << "replaced baseline " << idString((*res)["replaced"]) << " of the same configuration\n";
  }
  return 0;
}

int runBaselineList(ApiClient& api, bool all, Io& io) {
  auto res = api.listBaselines(all);
  return printListing(io, res, true, "baselines", baselineColumns(), [](const json& page, Table& t) {
    if (!page.contains("baselines") || !page["baselines"].is_array()) return;
    for (const auto& b : page["baselines"]) addBaselineRow(t, b);
  });
}

int runBaselineRemove(ApiClient& api, const std::string& id, Io& io) {
  auto res = api.removeBaseline(id);
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  io.out << "baseline " << id << " " << res->value("status", "") << "\n";
  return 0;
}

int runAlerts(ApiClient& api, const AlertsArgs& args, Io& io) {
  auto res = api.listAlerts(args.status, args.baseline, args.limit);
  std::vector<Table::Column> columns = {{"ID", Align::Right},      {"STATUS"},       {"BASELINE", Align::Right},
                                        {"RUN", Align::Right},     {"METRIC"},       {"VERDICT"},
                                        {"RATIO", Align::Right},   {"INTERVAL"},     {"P", Align::Right},
                                        {"A", Align::Right},       {"B", Align::Right}, {"CREATED"}};
  int rc = printListing(io, res, false, "alerts", columns, [](const json& page, Table& t) {
    if (!page.contains("alerts") || !page["alerts"].is_array()) return;
    for (const auto& a : page["alerts"]) {
      std::string interval = kMissing;
      if (a.contains("interval") && a["interval"].is_array() && a["interval"].size() == 2) {
        interval = "[" + fixed(std::optional<double>(a["interval"][0].get<double>()), 3) + ", " +
                   fixed(std::optional<double>(a["interval"][1].get<double>()), 3) + "]";
      }
      std::string metric = a.value("metric", "");
      if (a.value("kind", "") == "counts" && a.contains("details") && a["details"].is_object()) {
        metric += " (" + idString(a["details"].value("changed", json(0))) + " lines)";
      }
      bool counts = a.value("kind", "") == "counts";
      // Red for a regression, green for an improvement (web/views/alerts.js's
      // alertClass): time by its verdict, counts by whether the bytes went up.
      std::optional<Rgb> change = verdictColour(a.value("verdict", ""));
      if (a.value("kind", "") != "time" && a.contains("ratio") && a["ratio"].is_number())
        change = changeColour(a["ratio"].get<double>() - 1);
      t.addRow({idString(a.value("id", json())), a.value("status", ""), idString(a.value("baseline", json())),
                idString(a.value("run", json())), metric, a.value("verdict", ""), numberCell(a, "ratio", 3),
                interval, numberCell(a, "p_value", 4),
                counts ? humanBytes(a.value("value_a", json()).is_number()
                                        ? std::optional<double>(a["value_a"].get<double>())
                                        : std::nullopt)
                       : numberCell(a, "value_a", 3),
                counts ? humanBytes(a.value("value_b", json()).is_number()
                                        ? std::optional<double>(a["value_b"].get<double>())
                                        : std::nullopt)
                       : numberCell(a, "value_b", 3),
                a.value("created_at", "")},
               {std::nullopt, std::nullopt, std::nullopt, std::nullopt, std::nullopt, change, change});
    }
  });
  if (rc == 0 && res && !io.json && res->contains("counts") && (*res)["counts"].is_object()) {
    io.err << "open: " << idString((*res)["counts"].value("open", json(0))) << "\n";
  }
  return rc;
}

int runAlertStatus(ApiClient& api, const std::string& id, const std::string& status, Io& io) {
  auto res = api.setAlertStatus(id, status);
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  io.out << "alert " << id << " " << res->value("status", "") << "\n";
  return 0;
}

}  // namespace tally::client
