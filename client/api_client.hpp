// ApiClient: tallyd's REST API over cpp-httplib, returning JSON or a one-line
// reason. Every wire field name the client reads lives in api_client.cpp (the
// *View helpers), so aligning with the server is a change in one place.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "protocol.hpp"

namespace httplib {
class Client;
}

namespace tally::client {

using nlohmann::json;

// http://127.0.0.1:<protocol::kDefaultPort>
inline std::string defaultServer() { return "http://127.0.0.1:" + std::to_string(protocol::kDefaultPort); }
inline constexpr const char* kServerEnv = "TALLY_SERVER";  // overrides defaultServer()
inline constexpr const char* kTokenEnv = "TALLY_TOKEN";    // sent as Authorization: Bearer

struct ClientOptions {
  std::string server = defaultServer();  // http://host[:port]
  std::string token;                     // empty: no Authorization header
  int connectTimeoutS = 5;
  int readTimeoutS = 60;  // exports of many runs take a while
};

// --server when given, else $TALLY_SERVER, else defaultServer().
std::string resolveServer(const std::string& flag);
// $TALLY_TOKEN or empty.
std::string tokenFromEnv();

// Filters shared by /api/runs and /api/export; unset ones are not sent.
struct RunFilters {
  std::optional<std::string> renderer, scene, device, capture, runs;
  std::optional<std::string> variant;  // exact variant label
  std::optional<std::string> host;     // exact host name; /api/runs only (the export takes no host)
  std::optional<std::string> label;    // NAME=VALUE; /api/runs only
  std::optional<int> width, height;
};

// Filters of /api/sweeps; unset ones are not sent.
struct SweepFilters {
  std::optional<std::string> name, device, capture;
};

class ApiClient {
 public:
  explicit ApiClient(ClientOptions options);
  ~ApiClient();
  ApiClient(const ApiClient&) = delete;
  ApiClient& operator=(const ApiClient&) = delete;

  const std::string& server() const { return server_; }

  Result<json> health();
  Result<json> submitCapture(const json& spec, const std::string& idempotencyKey = "");
  Result<json> getCapture(const std::string& id);
  Result<json> listCaptures();
  Result<json> cancelCapture(const std::string& id);  // {} on 204
  // {"hosts": [...], "stale_after_s": N}: the daemons that share the store.
  Result<json> listHosts();
  // One page; cursor empty for the first.
  Result<json> listRuns(const RunFilters& filters, std::optional<int> limit, const std::string& cursor = "");
  // Follows next_cursor to the end; {"runs":[...every page's runs...]}.
  Result<json> listAllRuns(const RunFilters& filters, std::optional<int> limit);
  Result<json> getRun(const std::string& id);
  Result<json> getRunSamples(const std::string& id);
  Result<json> getSample(const std::string& id);
  // confidence, threshold: as GET /api/compare takes them; acrossCapture false: frames only.
  Result<json> compare(const std::vector<std::string>& runIds, std::optional<double> confidence = std::nullopt,
                       std::optional<double> threshold = std::nullopt, bool acrossCapture = true,
                       bool camerasAsStrata = true);
  // GET /api/crossover: fits against pixel count and crossings over a capture's runs.
  Result<json> crossover(const std::string& captureId, const std::string& metric);
  // GET /api/heatmap with these query parameters (empty values left out).
  Result<json> heatmap(const std::vector<std::pair<std::string, std::string>>& params);
  // One page of sweeps; cursor empty for the first.
  Result<json> listSweeps(const SweepFilters& filters, std::optional<int> limit, const std::string& cursor = "");
  // Follows next_cursor to the end; {"sweeps":[...every page's sweeps...]}.
  Result<json> listAllSweeps(const SweepFilters& filters, std::optional<int> limit);
  Result<json> getSweep(const std::string& id);
  // The export body, verbatim.
  Result<std::string> exportRuns(const std::string& format, const RunFilters& filters);
  // GET /api/samples/{id}/sites or /draws (what), with these query parameters (empty values left out).
  Result<json> sampleRows(const std::string& sampleId, const std::string& what,
                          const std::vector<std::pair<std::string, std::string>>& params);
  // GET /api/samples/{id}/trace: the sample as Chrome trace-event JSON, verbatim.
  Result<std::string> sampleTrace(const std::string& sampleId);
  // Baselines and alerts (docs/api.md, "Baselines and alerts").
  Result<json> setBaseline(const std::string& runId, std::optional<double> threshold,
                           const std::optional<std::string>& name);
  Result<json> listBaselines(bool all);
  Result<json> removeBaseline(const std::string& id);
  // One page of alerts, newest first; status and baseline empty: any.
  Result<json> listAlerts(const std::optional<std::string>& status, const std::optional<std::string>& baseline,
                          std::optional<int> limit, const std::string& cursor = "");
  Result<json> setAlertStatus(const std::string& id, const std::string& status);

 private:
  struct Raw {
    int status = 0;
    std::string body;
  };
  Result<Raw> send(const std::string& method, const std::string& path, const std::string& body = "",
                   const std::string& idempotencyKey = "");
  Result<json> sendJson(const std::string& method, const std::string& path, const std::string& body = "",
                        const std::string& idempotencyKey = "");

  std::string server_;
  std::string token_;
  std::unique_ptr<httplib::Client> http_;
};

// "error (400 invalid_field, field resolutions[0][0]): message", or for a body
// that is not the API's error object "error (502): <first line of the body>".
std::string formatHttpError(int status, const std::string& body);

// ---- the wire mapping: every response field the client reads -----------------

// An id that may arrive as a number or a string.
std::string idString(const json& value);

struct JobView {
  std::string id, status, error, current, createdAt;
  std::optional<int64_t> done, total;  // progress counts when the server gives them
  std::optional<double> fraction;      // 0..1, from counts or a bare number
  std::optional<int> attempts, maxAttempts;
  std::string host;                        // the host that holds or last ran it; "" for none
  std::string waiting;                     // a queued job: why no host runs it; "" when none is given
  std::vector<std::string> attemptErrors;  // why each earlier attempt ended, oldest first
  std::vector<std::string> runs;
  std::vector<std::string> sweeps;  // the sweep a finished sweep job stored
  bool finished() const {
    return status == protocol::kJobDone || status == protocol::kJobFailed ||
           status == protocol::kJobCancelled;
  }
};
JobView jobView(const json& job);
std::vector<json> jobList(const json& page);  // the "captures" array

struct RunView {
  std::string id, capture, renderer, scene, device, counting, createdAt;
  std::string host;  // the host that captured it; "" for runs stored before hosts existed
  std::string labels;  // its capture's labels, "commit=4f2a9c1,branch=main"; "" for none
  std::string tallyVersion, tallyCommit;  // the build that made it; "" for runs stored before builds recorded it
  // The variant label ("visbuffer barycentrics=float32"; the renderer for a
  // run without options or from a server before variants) and its options.
  std::string variant;
  nlohmann::json options = nlohmann::json::object();
  std::optional<int64_t> width, height, samples, lights, renderTargetBytes;
  std::optional<double> frameMs, bytes;  // means over the run's samples; bytes: requested bytes
  // Footprint: the block size (empty: off), the mean footprint per frame and
  // mean reuse (requested / footprint) over the samples; empty without footprint.
  std::optional<int64_t> footprintBlockBytes;
  std::optional<double> footprintBytes, reuse;
  bool hasFootprint() const { return footprintBytes.has_value(); }
};
RunView runView(const json& run);
std::vector<json> runList(const json& page);  // the "runs" array
std::string nextCursor(const json& page);     // empty at the end

// One daemon of the fleet (GET /api/hosts).
struct HostView {
  std::string name, role;
  bool probed = false;  // false: "device" is null (not probed yet)
  std::string deviceName, deviceVendor, driver, apiVersion;
  std::string deviceOverride;  // "" for none; else the name it reports in place of the device's
  std::string tallyVersion, tallyCommit, startedAt, lastHeartbeat;
  std::optional<double> secondsSinceHeartbeat;
  std::optional<bool> alive;  // heartbeat within stale_after_s
  std::optional<int64_t> jobsDone, jobsFailed;
  std::string currentJob;  // "" for none
};
HostView hostView(const json& host);
std::vector<json> hostList(const json& page);               // the "hosts" array
std::optional<double> staleAfterSeconds(const json& page);  // "stale_after_s"

struct SampleView {
  std::string id, camera;  // camera: label or index
  std::optional<double> skyFraction, frameMs, overhead, psnr, bytes, bytesRead, bytesWritten;
  std::optional<double> footprintBytes, reuse;  // empty without footprint
  bool identical = false;  // image equal to the reference renderer's
  std::string against;     // reference renderer of image_error
  // variant_error: the image against the run's reference variant (absent for
  // runs without options and for a variant that is its own reference).
  bool hasVariantError = false, variantIdentical = false;
  std::optional<double> variantPsnr;
  std::string variantAgainst;
};
SampleView sampleView(const json& sample);
std::vector<json> sampleList(const json& page);  // the "samples" array
// Bytes read and written per frame over a full sample's passes and counters.
std::pair<double, double> sampleReadWrite(const json& sample);

// One line of a run's passes (GET /api/runs/{id} "passes"): requested bytes,
// footprint and reuse per frame.
struct LineView {
  std::string pass, resource, access;
  std::optional<double> bytes, footprintBytes, reuse;
};
std::vector<LineView> runLines(const json& run);

// One compared quantity for one run (against the first run).
struct ComparedView {
  std::optional<double> value, delta, ratio;
};
struct CompareRow {
  // metric: "ms", "bytes" ("requested" beside "footprint" and "reuse" where a
  // compared run has a footprint), "count", "invocations"
  std::string pass, resource, metric;
  std::vector<ComparedView> values;    // one per run
  std::string access;                  // a resource's "read" or "write"; empty for the rest
};
struct CompareView {
  std::vector<RunView> runs;
  std::vector<CompareRow> rows;
};
CompareView compareView(const json& comparison);

struct SweepView {
  std::string id, capture, name, device, createdAt;
  std::optional<int64_t> points;
  std::vector<std::string> parameters;
  json threshold, failsAt;  // as the server gives them; failsAt null: nothing fails
};
SweepView sweepView(const json& sweep);
std::vector<json> sweepList(const json& page);  // the "sweeps" array

// One row of a sweep's fails_at: the swept parameter, the values that hold
// the group's other parameters fixed (key=value, space-separated), and the
// value where it fails (empty: the group holds over the range). fails_at is
// {param: [groups] | null} or one [groups] list; in a list, the swept
// parameter is the last of `parameters` that every group carries as a number
// or null.
struct FailsAtRow {
  std::string swept, group, value;
};
std::vector<FailsAtRow> failsAtRows(const json& failsAt, const std::vector<std::string>& parameters);
// A point's value at a dotted path ("error.max_relative"), or null.
json pointValue(const json& point, const std::string& dotted);

}  // namespace tally::client
