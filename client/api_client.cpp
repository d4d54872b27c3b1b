#include "api_client.hpp"

#include <cstdio>
#include <cstdlib>
#include <functional>
#include <sstream>

#include <httplib.h>

namespace tally::client {

namespace {

std::string trimSlash(std::string s) {
  while (!s.empty() && s.back() == '/') s.pop_back();
  return s;
}

std::string describe(httplib::Error error) {
  switch (error) {
    case httplib::Error::Connection: return "connection refused";
    case httplib::Error::ConnectionTimeout: return "connection timed out";
    case httplib::Error::Read: return "no response (read failed or timed out)";
    case httplib::Error::Write: return "request could not be sent";
    case httplib::Error::SSLConnection: return "TLS connection failed";
    case httplib::Error::SSLServerVerification: return "TLS certificate not trusted";
    default: return httplib::to_string(error);
  }
}

// Query string from (key, value) pairs, values percent-encoded.
std::string query(const std::vector<std::pair<std::string, std::string>>& params) {
  std::string out;
  for (const auto& [key, value] : params) {
    out += out.empty() ? "?" : "&";
    out += key + "=" + httplib::detail::encode_query_param(value);
  }
  return out;
}

std::vector<std::pair<std::string, std::string>> filterParams(const RunFilters& f) {
  std::vector<std::pair<std::string, std::string>> p;
  if (f.renderer) p.emplace_back("renderer", *f.renderer);
  if (f.variant) p.emplace_back("variant", *f.variant);
  if (f.scene) p.emplace_back("scene", *f.scene);
  if (f.width) p.emplace_back("width", std::to_string(*f.width));
  if (f.height) p.emplace_back("height", std::to_string(*f.height));
  if (f.device) p.emplace_back("device", *f.device);
  if (f.capture) p.emplace_back("capture", *f.capture);
  if (f.runs) p.emplace_back("runs", *f.runs);
  if (f.host) p.emplace_back("host", *f.host);
  if (f.label) p.emplace_back("label", *f.label);
  return p;
}

std::vector<std::pair<std::string, std::string>> sweepParams(const SweepFilters& f) {
  std::vector<std::pair<std::string, std::string>> p;
  if (f.name) p.emplace_back("name", *f.name);
  if (f.device) p.emplace_back("device", *f.device);
  if (f.capture) p.emplace_back("capture", *f.capture);
  return p;
}

std::string pathId(const std::string& id) { return httplib::detail::encode_query_param(id); }

}  // namespace

std::string resolveServer(const std::string& flag) {
  if (!flag.empty()) return trimSlash(flag);
  const char* env = std::getenv(kServerEnv);
  if (env && *env) return trimSlash(env);
  return defaultServer();
}

std::string tokenFromEnv() {
  const char* env = std::getenv(kTokenEnv);
  return env ? env : "";
}

ApiClient::ApiClient(ClientOptions options) : server_(trimSlash(options.server)), token_(options.token) {
  if (server_.find("://") == std::string::npos) server_ = "http://" + server_;
  http_ = std::make_unique<httplib::Client>(server_);
  http_->set_connection_timeout(options.connectTimeoutS, 0);
  http_->set_read_timeout(options.readTimeoutS, 0);
  http_->set_write_timeout(options.readTimeoutS, 0);
  http_->set_keep_alive(false);
  if (!token_.empty()) http_->set_bearer_token_auth(token_);
}

ApiClient::~ApiClient() = default;

Result<ApiClient::Raw> ApiClient::send(const std::string& method, const std::string& path,
                                       const std::string& body, const std::string& idempotencyKey) {
  if (!http_->is_valid())
    return makeError("invalid --server URL '" + server_ + "' (expected http://HOST:PORT)");
  httplib::Headers headers;
  if (!idempotencyKey.empty()) headers.emplace("Idempotency-Key", idempotencyKey);
  httplib::Result res{nullptr, httplib::Error::Unknown};
  if (method == "GET") {
    res = http_->Get(path, headers);
  } else if (method == "POST") {
    res = http_->Post(path, headers, body, "application/json");
  } else if (method == "PATCH") {
    res = http_->Patch(path, headers, body, "application/json");
  } else if (method == "DELETE") {
    res = http_->Delete(path, headers);
  } else {
    return makeError("unsupported method " + method);
  }
  if (!res) {
    return makeError("cannot reach tallyd at " + server_ + ": " + describe(res.error()) +
                     " (is `tallyd serve` running?)");
  }
  if (res->status >= 400) return makeError(formatHttpError(res->status, res->body));
  return Raw{res->status, res->body};
}

Result<json> ApiClient::sendJson(const std::string& method, const std::string& path, const std::string& body,
                                 const std::string& idempotencyKey) {
  auto raw = send(method, path, body, idempotencyKey);
  if (!raw) return makeError(raw.error());
  if (raw->body.empty()) return json::object();
  json parsed = json::parse(raw->body, nullptr, false);
  if (parsed.is_discarded()) {
    return makeError("tallyd at " + server_ + " sent a response that is not JSON (HTTP " +
                     std::to_string(raw->status) + ")");
  }
  return parsed;
}

Result<json> ApiClient::health() { return sendJson("GET", "/api/health"); }

Result<json> ApiClient::submitCapture(const json& spec, const std::string& idempotencyKey) {
  return sendJson("POST", "/api/captures", spec.dump(), idempotencyKey);
}
Result<json> ApiClient::getCapture(const std::string& id) {
  return sendJson("GET", "/api/captures/" + pathId(id));
}
Result<json> ApiClient::listCaptures() { return sendJson("GET", "/api/captures"); }
Result<json> ApiClient::cancelCapture(const std::string& id) {
  return sendJson("DELETE", "/api/captures/" + pathId(id));
}
Result<json> ApiClient::listHosts() { return sendJson("GET", "/api/hosts"); }

namespace {

using Params = std::vector<std::pair<std::string, std::string>>;

// One page of a listing: the filters, then limit and cursor when given.
std::string pageQuery(Params params, std::optional<int> limit, const std::string& cursor) {
  if (limit) params.emplace_back("limit", std::to_string(*limit));
  if (!cursor.empty()) params.emplace_back("cursor", cursor);
  return query(params);
}

// Follows next_cursor from the first page to the end: {key: [...every page's items...]}.
Result<json> allPages(const std::string& key, const std::function<Result<json>(const std::string& cursor)>& page,
                      const std::function<std::vector<json>(const json&)>& items) {
  json all = {{key, json::array()}};
  std::string cursor;
  for (int n = 0; n < 100000; ++n) {  // a server that loops its cursor must not hang us forever
    auto res = page(cursor);
    if (!res) return res;
    for (auto& item : items(*res)) all[key].push_back(std::move(item));
    std::string next = nextCursor(*res);
    if (next.empty() || next == cursor) break;
    cursor = next;
  }
  return all;
}

}  // namespace

Result<json> ApiClient::listRuns(const RunFilters& filters, std::optional<int> limit,
                                 const std::string& cursor) {
  return sendJson("GET", "/api/runs" + pageQuery(filterParams(filters), limit, cursor));
}

Result<json> ApiClient::listAllRuns(const RunFilters& filters, std::optional<int> limit) {
  return allPages(
      "runs", [&](const std::string& cursor) { return listRuns(filters, limit, cursor); }, runList);
}

Result<json> ApiClient::setBaseline(const std::string& runId, std::optional<double> threshold,
                                    const std::optional<std::string>& name) {
  json body;
  try {
    size_t used = 0;
    long long id = std::stoll(runId, &used);
    if (used != runId.size() || id < 1) throw std::invalid_argument("not positive");
    body["run"] = id;
  } catch (const std::exception&) {
    return makeError("RUN: must be a run id (a positive integer), got '" + runId + "'");
  }
  if (threshold) body["threshold"] = *threshold;
  if (name) body["name"] = *name;
  return sendJson("POST", "/api/baselines", body.dump());
}

Result<json> ApiClient::listBaselines(bool all) {
  return sendJson("GET", "/api/baselines" + (all ? query({{"all", "true"}}) : std::string()));
}

Result<json> ApiClient::removeBaseline(const std::string& id) {
  return sendJson("DELETE", "/api/baselines/" + pathId(id));
}

Result<json> ApiClient::listAlerts(const std::optional<std::string>& status, const std::optional<std::string>& baseline,
                                   std::optional<int> limit, const std::string& cursor) {
  Params params;
  if (status) params.emplace_back("status", *status);
  if (baseline) params.emplace_back("baseline", *baseline);
  return sendJson("GET", "/api/alerts" + pageQuery(params, limit, cursor));
}

Result<json> ApiClient::setAlertStatus(const std::string& id, const std::string& status) {
  return sendJson("PATCH", "/api/alerts/" + pathId(id), json{{"status", status}}.dump());
}

Result<json> ApiClient::getRun(const std::string& id) { return sendJson("GET", "/api/runs/" + pathId(id)); }
Result<json> ApiClient::getRunSamples(const std::string& id) {
  return sendJson("GET", "/api/runs/" + pathId(id) + "/samples");
}
Result<json> ApiClient::getSample(const std::string& id) {
  return sendJson("GET", "/api/samples/" + pathId(id));
}

Result<json> ApiClient::compare(const std::vector<std::string>& runIds, std::optional<double> confidence,
                                std::optional<double> threshold, bool acrossCapture, bool camerasAsStrata) {
  std::string ids;
  for (const auto& id : runIds) ids += (ids.empty() ? "" : ",") + id;
  std::vector<std::pair<std::string, std::string>> params = {{"runs", ids}};
  auto number = [](double v) {
    std::ostringstream s;
    s.precision(17);
    s << v;
    return s.str();
  };
  if (confidence) params.emplace_back("confidence", number(*confidence));
  if (threshold) params.emplace_back("threshold", number(*threshold));
  if (!acrossCapture) params.emplace_back("across_capture", "false");
  if (!camerasAsStrata) params.emplace_back("strata", "none");
  return sendJson("GET", "/api/compare" + query(params));
}

Result<json> ApiClient::crossover(const std::string& captureId, const std::string& metric) {
  return sendJson("GET", "/api/crossover" + query({{"capture", captureId}, {"metric", metric}}));
}

Result<json> ApiClient::heatmap(const std::vector<std::pair<std::string, std::string>>& params) {
  std::vector<std::pair<std::string, std::string>> given;
  for (const auto& p : params)
    if (!p.second.empty()) given.push_back(p);
  return sendJson("GET", "/api/heatmap" + query(given));
}

Result<json> ApiClient::listSweeps(const SweepFilters& filters, std::optional<int> limit,
                                   const std::string& cursor) {
  return sendJson("GET", "/api/sweeps" + pageQuery(sweepParams(filters), limit, cursor));
}

Result<json> ApiClient::listAllSweeps(const SweepFilters& filters, std::optional<int> limit) {
  return allPages(
      "sweeps", [&](const std::string& cursor) { return listSweeps(filters, limit, cursor); }, sweepList);
}

Result<json> ApiClient::getSweep(const std::string& id) { return sendJson("GET", "/api/sweeps/" + pathId(id)); }

Result<std::string> ApiClient::exportRuns(const std::string& format, const RunFilters& filters) {
  auto params = filterParams(filters);
  params.insert(params.begin(), {"format", format});
  auto raw = send("GET", "/api/export" + query(params));
  if (!raw) return makeError(raw.error());
  return raw->body;
}

Result<json> ApiClient::sampleRows(const std::string& sampleId, const std::string& what,
                                   const std::vector<std::pair<std::string, std::string>>& params) {
  std::vector<std::pair<std::string, std::string>> given;
  for (const auto& p : params)
    if (!p.second.empty()) given.push_back(p);
  return sendJson("GET", "/api/samples/" + pathId(sampleId) + "/" + what + query(given));
}

Result<std::string> ApiClient::sampleTrace(const std::string& sampleId) {
  auto raw = send("GET", "/api/samples/" + pathId(sampleId) + "/trace");
  if (!raw) return makeError(raw.error());
  return raw->body;
}

}  // namespace tally::client
