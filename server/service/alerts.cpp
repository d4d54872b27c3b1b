// Baselines, alerts and a configuration's trend as JSON routes
// (docs/api.md, "Baselines and alerts"). The evaluation that raises alerts
// runs elsewhere (alert_evaluator.cpp); these routes read and change rows.
#include "service/alerts.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "reports/frame_time.hpp"
#include "service/routes.hpp"
#include "service/webhook.hpp"

namespace tally::service {

using api::Request;
using api::Response;
using nlohmann::json;
using namespace detail;

namespace {

// The longest name a baseline may have.
constexpr size_t kMaxBaselineName = 128;
// Runs a trend gives at most (the newest), and by default.
constexpr int kMaxTrendRuns = 500;
constexpr int kDefaultTrendRuns = 100;

// The body's fields other than `known` are refused, naming the first.
void allowFields(const json& body, const std::vector<std::string>& known) {
  if (!body.is_object()) throw RequestError(400, api::code::kBadJson, "the body must be a JSON object");
  for (const auto& [key, value] : body.items()) {
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      invalid(key, "unknown field (expected " + list + ")");
    }
  }
}

// POST /api/baselines {"run": ID, "threshold": 0.05, "name": "..."}
Response postBaseline(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  const json& body = req.body;
  allowFields(body, {"run", "threshold", "name"});
  if (!body.contains("run")) invalid("run", "required: the id of the run to make the baseline");
  if (!body["run"].is_number_integer() || body["run"].get<int64_t>() < 1)
    invalid("run", "must be a positive integer");
  store::NewBaseline nb;
  nb.runId = body["run"].get<int64_t>();
  if (body.contains("threshold")) {
    const json& t = body["threshold"];
    if (!t.is_number() || !std::isfinite(t.get<double>()) || t.get<double>() < 0 || t.get<double>() > 10) {
      invalid("threshold",
              "must be a number from 0 to 10 (|ratio - 1| beyond which a time change alerts; 0.05: 5%)");
    }
    nb.threshold = t.get<double>();
  }
  if (body.contains("name") && !body["name"].is_null()) {
    const json& n = body["name"];
    bool control = n.is_string() &&
                   std::any_of(n.get_ref<const std::string&>().begin(), n.get_ref<const std::string&>().end(),
                               [](char c) { return static_cast<unsigned char>(c) < 0x20; });
    if (!n.is_string() || n.get<std::string>().empty() || n.get<std::string>().size() > kMaxBaselineName ||
        control) {
      invalid("name",
              "must be 1 to " + std::to_string(kMaxBaselineName) + " characters without control characters");
    }
    nb.name = n.get<std::string>();
  }
  auto set = check(ctx.writer->alerts().setBaseline(nb));
  if (!set) missing("no run " + std::to_string(nb.runId));
  json out = baselineJson(set->baseline);
  out["replaced"] = opt(set->replaced);
  Response r = Response::ok(out, 201);
  r.headers.emplace_back("Location", "/api/baselines/" + std::to_string(set->baseline.id));
  return r;
}

Response listBaselines(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"all"});
  json out = json::array();
  for (const auto& b : check(reader(ctx).alerts().listBaselines(queryBool(req, "all").value_or(false))))
    out.push_back(baselineJson(b));
  return Response::ok({{"baselines", out}});
}

Response getBaseline(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto b = check(reader(ctx).alerts().getBaseline(id));
  if (!b) missing("no baseline " + std::to_string(id));
  return Response::ok(baselineJson(*b));
}

Response deleteBaseline(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto b = check(ctx.writer->alerts().removeBaseline(id));
  if (!b) missing("no baseline " + std::to_string(id));
  return Response::ok(baselineJson(*b));
}

std::optional<store::AlertStatus> queryStatus(const Request& req) {
  auto s = queryString(req, "status", 32);
  if (!s) return std::nullopt;
  auto status = store::parseAlertStatus(*s);
  if (!status) invalid("status", "must be open, acknowledged, invalid or fixed");
  return status;
}

Response listAlerts(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"status", "baseline", "run", "limit", "cursor"});
  store::AlertFilter filter;
  filter.status = queryStatus(req);
  filter.baselineId = queryInt(req, "baseline", 1, INT64_MAX);
  filter.runId = queryInt(req, "run", 1, INT64_MAX);
  auto& store = reader(ctx);
  auto page = check(store.alerts().list(filter, queryPage(req)));
  json alerts = json::array();
  for (const auto& a : page.alerts) alerts.push_back(alertJson(a));
  return Response::ok({{"alerts", alerts},
                       {"next_cursor", page.nextCursor.empty() ? json(nullptr) : json(page.nextCursor)},
                       {"counts", check(store.alerts().counts(filter.baselineId))}});
}

Response getAlert(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto& store = reader(ctx);
  auto a = check(store.alerts().get(id));
  if (!a) missing("no alert " + std::to_string(id));
  json out = alertJson(*a);
  auto run = check(store.runs().get(a->runId));
  if (run) {
    auto frameTime = check(reports::frameTimeOf(store, run->row));
    out["run_row"] = runRowJson(run->row, &frameTime);
  } else {
    out["run_row"] = nullptr;
  }
  auto baseline = check(store.alerts().getBaseline(a->baselineId));
  out["baseline_row"] = baseline ? baselineJson(*baseline) : json(nullptr);
  return Response::ok(out);
}

// PATCH or POST /api/alerts/{id} {"status": "acknowledged"}
Response updateAlert(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  allowFields(req.body, {"status"});
  if (!req.body.contains("status")) invalid("status", "required: open, acknowledged, invalid or fixed");
  const json& s = req.body["status"];
  auto status = s.is_string() ? store::parseAlertStatus(s.get<std::string>()) : std::nullopt;
  if (!status) invalid("status", "must be open, acknowledged, invalid or fixed");
  auto a = check(ctx.writer->alerts().setStatus(id, *status));
  if (!a) missing("no alert " + std::to_string(id));
  return Response::ok(alertJson(*a));
}

// GET /api/trend?baseline=ID[&limit=N]: every run of the baseline's
// configuration, oldest first, with its date, labels, frame time and bytes,
// and every alert raised on the configuration.
Response trend(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"baseline", "limit"});
  auto id = queryInt(req, "baseline", 1, INT64_MAX);
  if (!id) invalid("baseline", "required: a baseline id (GET /api/baselines)");
  int limit = static_cast<int>(queryInt(req, "limit", 1, kMaxTrendRuns).value_or(kDefaultTrendRuns));
  auto& store = reader(ctx);
  auto baseline = check(store.alerts().getBaseline(*id));
  if (!baseline) missing("no baseline " + std::to_string(*id));
  auto alerts = check(store.alerts().configurationAlerts(*id, 1000));
  std::map<int64_t, json> alertsByRun;
  json alertList = json::array();
  for (const auto& a : alerts) {
    alertsByRun[a.runId].push_back(a.id);
    alertList.push_back(alertJson(a));
  }
  auto configurationRuns = check(store.alerts().configurationRuns(*id, limit));
  auto frameTimes = check(reports::frameTimesOf(store, configurationRuns));
  json runs = json::array();
  for (const auto& r : configurationRuns) {
    runs.push_back({{"id", r.id},
                    {"capture", r.jobId},
                    {"created_at", r.createdAt},
                    {"labels", r.labels},
                    {"lights", r.lights},
                    {"host", opt(r.host)},
                    {"tally_commit", opt(r.tallyCommit)},
                    {"frame_ms", reports::toJson(frameTimes[r.id])},
                    {"mean_bytes", opt(r.meanBytes)},
                    {"baseline", r.id == baseline->runId},
                    {"alerts", alertsByRun.count(r.id) ? alertsByRun[r.id] : json::array()}});
  }
  return Response::ok({{"baseline", baselineJson(*baseline)}, {"runs", runs}, {"alerts", alertList}});
}

}  // namespace

void addAlertRoutes(api::Router& router, ServiceContext& ctx) {
  auto route = [&ctx](RouteHandler fn) { return routed(ctx, fn); };
  router.post("/api/baselines", route(postBaseline));
  router.get("/api/baselines", route(listBaselines));
  router.get("/api/baselines/{id}", route(getBaseline));
  router.del("/api/baselines/{id}", route(deleteBaseline));
  router.get("/api/alerts", route(listAlerts));
  router.get("/api/alerts/{id}", route(getAlert));
  router.add("PATCH", "/api/alerts/{id}", route(updateAlert));
  router.post("/api/alerts/{id}", route(updateAlert));
  router.get("/api/trend", route(trend));
}

}  // namespace tally::service
