// A fake tallyd for the client tests: an in-process httplib::Server on
// 127.0.0.1 (ephemeral port) serving canned JSON for every route the client
// calls. Capture 7 goes queued -> running -> running -> done over successive
// polls; capture 8 fails; run 404 and compare of run 99 give API errors;
// /api/crossover answers for capture 7 only (crossoverJson); /api/heatmap
// gives one 3x1 grid of visbuffer against deferred.
// A fleet: /api/hosts lists three hosts (kHostsJson); capture 9 is queued
// with a waiting reason after a lost attempt, capture 10 runs on gpu-a on
// its second attempt, capture 11 (a spec with "waits") waits, then runs to
// the end; runs filtered by host (and run 21) carry their host.
// Baselines (run 99: none) and alerts (a time and a counts alert of run 15;
// alert 99: none), with the last body and query kept; runs filtered by label
// carry labels.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <mutex>
#include <string>
#include <thread>

#include <httplib.h>
#include <nlohmann/json.hpp>

namespace tally::client::test {

using nlohmann::json;

inline json apiError(const std::string& code, const std::string& message, const std::string& field = "") {
  json e = {{"code", code}, {"message", message}};
  if (!field.empty()) e["field"] = field;
  return {{"error", e}};
}

inline json runJson(int id, const std::string& renderer, int width) {
  return {{"id", id},
          {"capture", 7},
          {"renderer", renderer},
          {"scene", "atrium"},
          {"width", width},
          {"height", 180},
          {"device", "llvmpipe (LLVM 15.0.6, 256 bits)"},
          {"counting", "exact"},
          {"lights", 400},
          {"sample_count", 2},
          {"mean_frame_ms", 1.834},
          {"mean_bytes", 3145728.0},
          {"render_target_bytes", 1048576},
          {"extra_field", {1, 2}}};
}

// GET /api/crossover?capture=7: deferred and visbuffer fitted over three
// resolutions (visbuffer's fit poor), forward with two runs (no fit); they
// cross at 800,000 pixels (1193x671), and deferred and forward-zprepass are parallel.
inline json crossoverJson(const std::string& metric) {
  auto fit = [](double a, double b, double r2, bool poor) {
    json points = json::array();
    int run = 30;
    for (auto [w, h] : {std::pair{640, 360}, {1280, 720}, {1920, 1080}}) {
      double p = double(w) * h;
      points.push_back({{"pixels", p}, {"value", a + b * p + 1000}, {"residual", 1000.0}, {"run", run++},
                        {"width", w}, {"height", h}});
    }
    return json{{"n", 3}, {"a", a}, {"b", b}, {"a_se", a / 100}, {"b_se", b / 100}, {"a_ci", {a * 0.9, a * 1.1}},
                {"b_ci", {b * 0.9, b * 1.1}}, {"residual_se", 1000.0}, {"r2", r2}, {"poor_fit", poor},
                {"confidence", 0.95}, {"min_pixels", 230400.0}, {"max_pixels", 2073600.0}, {"points", points}};
  };
  auto series = [](const std::string& variant, json f, json error) {
    return json{{"variant", variant}, {"renderer", variant}, {"scene", "atrium"}, {"scene_params", json::object()},
                {"device_id", 1}, {"device", "llvmpipe"}, {"counting", "exact"}, {"lights", 4},
                {"footprint_block_bytes", nullptr}, {"runs", {30, 31, 32}}, {"fit", f}, {"error", error}};
  };
  return {{"capture", 7},
          {"metric", metric},
          {"model", "y = a + b * pixels (ordinary least squares)"},
          {"confidence", 0.95},
          {"poor_fit_r2", 0.9},
          {"interval_method", "delta"},
          {"series",
           {series("deferred", fit(1048576, 40, 0.9991, false), nullptr),
            series("visbuffer", fit(9437184, 30, 0.61, true), nullptr),
            series("forward", nullptr, "a fit needs at least 3 resolutions, got 2")}},
          {"crossings",
           {{{"first", "deferred"}, {"second", "visbuffer"}, {"scene", "atrium"}, {"device_id", 1}, {"kind", "crosses"},
             {"pixels", 800000.0}, {"pixels_se", 20000.0}, {"pixels_ci", {760000.0, 840000.0}},
             {"resolution", {{"width", 1193}, {"height", 671}}},
             {"resolution_ci", {{{"width", 1162}, {"height", 654}}, {{"width", 1222}, {"height", 687}}}},
             {"range", {230400.0, 2073600.0}}, {"slope_difference", 10.0}, {"slope_difference_se", 0.5},
             {"lower_below", "deferred"}, {"lower_above", "visbuffer"}, {"lower_throughout", nullptr},
             {"confidence", 0.95}, {"degrees_of_freedom", 2}, {"interval_method", "delta"}},
            {{"first", "deferred"}, {"second", "forward-zprepass"}, {"scene", "atrium"}, {"device_id", 1},
             {"kind", "parallel"}, {"pixels", nullptr}, {"pixels_se", nullptr}, {"pixels_ci", nullptr},
             {"resolution", nullptr}, {"resolution_ci", nullptr}, {"range", {230400.0, 2073600.0}},
             {"slope_difference", 0.1}, {"slope_difference_se", 0.5}, {"lower_below", nullptr},
             {"lower_above", nullptr}, {"lower_throughout", "deferred"}, {"confidence", 0.95},
             {"degrees_of_freedom", 2}, {"interval_method", "delta"}}}},
          {"truncated", false}};
}

// Run 16: a variant of visbuffer (its options set, "variant" its label).
inline json variantRunJson(int id) {
  json run = runJson(id, "visbuffer", 320);
  run["options"] = {{"barycentrics", "float32"}, {"material_selection", "uniform"}};
  run["variant"] = "visbuffer barycentrics=float32 material_selection=uniform";
  return run;
}

// Run 18: counted with footprint (64-byte blocks): its mean footprint and
// reuse, and per line (in "passes") the requested bytes beside the footprint.
inline json footprintRunJson(int id) {
  json run = runJson(id, "deferred", 320);
  run["counting"] = "accumulate";
  run["footprint_block_bytes"] = 64;
  run["mean_footprint_bytes"] = 1048576.0;
  run["mean_reuse"] = 3.0;
  run["passes"] = {{{"name", "gbuffer"},
                    {"resources",
                     {{{"name", "material_maps.diffuse"},
                       {"access", "read"},
                       {"bytes", 2097152.0},
                       {"footprint_bytes", 524288.0},
                       {"reuse", 4.0}},
                      {{"name", "depth"}, {"access", "write"}, {"bytes", 4096.0}, {"footprint_bytes", nullptr},
                       {"reuse", nullptr}}}}}};
  return run;
}

// GET /api/hosts: gpu-a and gpu-b alive (gpu-b reports an overridden
// device name), gpu-c stale and never probed.
inline json hostsJson() {
  return json::parse(R"({"hosts": [
    {"name": "gpu-a", "role": "worker",
     "device": {"name": "NVIDIA H100 80GB HBM3", "vendor": "NVIDIA", "driver": "550.54.15", "api_version": "1.3.280"},
     "device_override": null, "tally_version": "0.1.0", "tally_commit": "abc1234",
     "started_at": "2026-11-21T06:00:00Z", "last_heartbeat": "2026-11-21T06:30:00Z",
     "seconds_since_heartbeat": 3.2, "alive": true, "jobs_done": 4, "jobs_failed": 1, "current_job": 12},
    {"name": "gpu-b", "role": "all",
     "device": {"name": "NVIDIA H200", "vendor": "NVIDIA", "driver": "560.35.03", "api_version": "1.3.289"},
     "device_override": "FakeGPU-A", "tally_version": "0.1.0", "tally_commit": "abc1234",
     "started_at": "2026-11-21T06:00:05Z", "last_heartbeat": "2026-11-21T06:30:03Z",
     "seconds_since_heartbeat": 0.4, "alive": true, "jobs_done": 0, "jobs_failed": 0, "current_job": null},
    {"name": "gpu-c", "role": "worker", "device": null, "device_override": null,
     "tally_version": "0.1.0", "tally_commit": "def5678",
     "started_at": "2026-11-21T05:00:00Z", "last_heartbeat": "2026-11-21T06:28:00Z",
     "seconds_since_heartbeat": 125.0, "alive": false, "jobs_done": 7, "jobs_failed": 2, "current_job": null}
  ], "stale_after_s": 30})");
}

inline const char* const kWaitingReason = R"(no live worker has a device matching {"name":"AMD"})";
inline const char* const kLostAttempt = "attempt 1 on gpu-b: lease expired (no heartbeat for 31 s)";

class FakeTallyd {
 public:
  // port 0: an ephemeral port; else that port (to stand in for a restarted daemon).
  explicit FakeTallyd(int port = 0) {
    auto reply = [](httplib::Response& res, const json& body, int status = 200) {
      res.status = status;
      res.set_content(body.dump(), "application/json");
    };
    server_.Post("/api/captures", [this, reply](const httplib::Request& req, httplib::Response& res) {
      std::lock_guard lock(mutex_);
      lastSpec_ = req.body;
      lastIdempotencyKey_ = req.get_header_value("Idempotency-Key");
      lastAuthorization_ = req.get_header_value("Authorization");
      json spec = json::parse(req.body, nullptr, false);
      if (spec.is_discarded() || !spec.contains("renderers")) {
        return reply(res, apiError("invalid_field", "renderers: required", "renderers"), 400);
      }
      if (spec.contains("resolutions") && spec["resolutions"].dump() == "[[0,180]]") {
        return reply(
            res,
            apiError("invalid_field", "must be an integer between 1 and 16384, got 0", "resolutions[0][0]"),
            400);
      }
      int id = spec.value("fail", false) ? 8 : spec.value("waits", false) ? 11 : 7;
      reply(res, {{"id", id}, {"status", "queued"}}, 202);
    });
    server_.Get(R"(/api/captures/(\d+))", [this, reply](const httplib::Request& req, httplib::Response& res) {
      int id = std::stoi(req.matches[1]);
      int poll = 0;
      {
        std::lock_guard lock(mutex_);
        poll = polls_[id]++;
      }
      if (id == 7) {
        static const char* const kStates[] = {"queued", "running", "running", "done"};
        std::string status = kStates[std::min(poll, 3)];
        json job = {{"id", 7},
                    {"status", status},
                    {"attempts", status == "queued" ? 0 : 1},
                    {"created_at", "2026-11-21T06:30:00.000Z"}};
        int done = std::min(poll, 3) == 3 ? 40 : (poll == 2 ? 12 : 0);
        job["progress"] = {{"done", done}, {"total", 40}, {"current", "deferred atrium 320x180 camera 3"}};
        if (status == "done") job["runs"] = {12, 15};
        return reply(res, job);
      }
      if (id == 8) {
        json job = {{"id", 8},
                    {"status", poll == 0 ? "running" : "failed"},
                    {"attempts", 1},
                    {"progress", {{"done", 1}, {"total", 4}}}};
        if (poll > 0) job["error"] = "device lost during deferred atrium 320x180 camera 1";
        return reply(res, job);
      }
      if (id == 9) {
        return reply(res, {{"id", 9},
                           {"status", "queued"},
                           {"host", nullptr},
                           {"attempts", 1},
                           {"max_attempts", 3},
                           {"attempt_errors", {kLostAttempt}},
                           {"waiting", kWaitingReason},
                           {"progress", {{"done", 0}, {"total", 4}}}});
      }
      if (id == 10) {
        return reply(res, {{"id", 10},
                           {"status", "running"},
                           {"host", "gpu-a"},
                           {"attempts", 2},
                           {"max_attempts", 3},
                           {"attempt_errors", {kLostAttempt}},
                           {"waiting", nullptr},
                           {"progress", {{"done", 2}, {"total", 4}}}});
      }
      if (id == 11) {  // waits for a device, then runs on gpu-a
        json job = {{"id", 11},
                    {"attempts", poll == 0 ? 0 : 1},
                    {"max_attempts", 3},
                    {"attempt_errors", json::array()}};
        job["status"] = poll == 0 ? "queued" : poll == 1 ? "running" : "done";
        job["host"] = poll == 0 ? json(nullptr) : json("gpu-a");
        job["waiting"] = poll == 0 ? json(kWaitingReason) : json(nullptr);
        job["progress"] = {{"done", poll == 0 ? 0 : 4}, {"total", 4}};
        if (poll >= 2) job["runs"] = {21};
        return reply(res, job);
      }
      reply(res, apiError("not_found", "capture " + std::to_string(id) + " not found"), 404);
    });
    server_.Get("/api/captures", [reply](const httplib::Request&, httplib::Response& res) {
      reply(res, {{"captures",
                   {{{"id", 9},
                     {"status", "queued"},
                     {"host", nullptr},
                     {"attempts", 1},
                     {"max_attempts", 3},
                     {"attempt_errors", {kLostAttempt}},
                     {"waiting", kWaitingReason},
                     {"progress", {{"done", 0}, {"total", 4}}},
                     {"created_at", "2026-11-21T06:32:00Z"}},
                    {{"id", 8},
                     {"host", "gpu-b"},
                     {"status", "failed"},
                     {"attempts", 2},
                     {"error", "out of memory"},
                     {"progress", {{"done", 1}, {"total", 4}}},
                     {"created_at", "2026-11-21T06:31:00Z"}},
                    {{"id", 7},
                     {"status", "running"},
                     {"host", "gpu-a"},
                     {"attempts", 1},
                     {"max_attempts", 3},
                     {"progress", {{"done", 12}, {"total", 40}}},
                     {"created_at", "2026-11-21T06:30:00Z"}}}},
                  {"next_cursor", nullptr}});
    });
    server_.Delete(R"(/api/captures/(\d+))",
                   [](const httplib::Request&, httplib::Response& res) { res.status = 204; });
    server_.Get("/api/runs", [this, reply](const httplib::Request& req, httplib::Response& res) {
      {
        std::lock_guard lock(mutex_);
        lastRunsQuery_ = req.params;
      }
      std::string cursor = req.get_param_value("cursor");
      if (req.has_param("label")) {  // a run of a labelled capture
        json run = runJson(15, "deferred", 320);
        run["labels"] = {{"branch", "main"}, {"commit", "4f2a9c1"}};
        return reply(res, {{"runs", {run}}, {"next_cursor", nullptr}});
      }
      if (req.has_param("host")) {
        json run = runJson(21, "deferred", 320);
        run["host"] = req.get_param_value("host");
        return reply(res, {{"runs", {run}}, {"next_cursor", nullptr}});
      }
      if (req.get_param_value("capture") == "21") {  // a fleet's run beside one stored before hosts
        json run = runJson(21, "deferred", 320);
        run["host"] = "gpu-a";
        json old = runJson(12, "deferred", 320);
        old["host"] = nullptr;
        return reply(res, {{"runs", {run, old}}, {"next_cursor", nullptr}});
      }
      if (req.has_param("variant"))
        return reply(res, {{"runs", {variantRunJson(16)}}, {"next_cursor", nullptr}});
      if (req.get_param_value("capture") == "18")
        return reply(res, {{"runs", {footprintRunJson(18), runJson(12, "deferred", 320)}}, {"next_cursor", nullptr}});
      if (cursor.empty())
        return reply(res, {{"runs", {runJson(15, "visbuffer", 320), runJson(12, "deferred", 320)}},
                           {"next_cursor", "r9"}});
      if (cursor == "r9")
        return reply(res, {{"runs", {runJson(9, "forward", 640)}}, {"next_cursor", nullptr}});
      reply(res, apiError("bad_query", "cursor: not a cursor", "cursor"), 400);
    });
    server_.Get(R"(/api/runs/(\d+))", [reply](const httplib::Request& req, httplib::Response& res) {
      int id = std::stoi(req.matches[1]);
      if (id == 404) return reply(res, apiError("not_found", "run 404 not found"), 404);
      if (id == 16) return reply(res, variantRunJson(id));
      if (id == 21) {
        json run = runJson(id, "deferred", 320);
        run["host"] = "gpu-a";
        return reply(res, run);
      }
      if (id == 18) return reply(res, footprintRunJson(id));
      if (id == 17) {  // a user's glTF scene: the loader's notes and the renderer's
        json run = runJson(id, "forward", 320);
        run["scene"] = "ToyCar";
        run["notes"] = {{"scene", {"KHR_materials_clearcoat: used but not implemented; clearcoat is not drawn"}},
                        {"zprepass_fragment_shader", "counting_only"}};
        return reply(res, run);
      }
      if (id == 19) {  // a run whose capture measured the device's ceilings
        json run = runJson(id, "deferred", 320);
        run["ceilings"] = {{"bandwidth_bytes_per_s", 5.3e9}, {"arithmetic_ops_per_s", 1.234e11},
                           {"ridge_intensity", 23.5}, {"copy_bytes", 67108864}, {"method", json::object()}};
        return reply(res, run);
      }
      reply(res, runJson(id, "deferred", 320));
    });
    server_.Get(R"(/api/runs/(\d+)/samples)", [reply](const httplib::Request& req, httplib::Response& res) {
      json samples = {{"samples",
                   {{{"id", 101},
                     {"camera", 0},
                     {"sky_fraction", 0.31},
                     {"frame_ms", 1.83},
                     {"overhead_ratio", 1.1},
                     {"bytes", 3072.0},
                     {"image_error", {{"against", "forward"}, {"psnr", 41.25}, {"identical", false}}}},
                    {{"id", 102},
                     {"camera", {{"eye", {0, 1, 2}}, {"label", "half sky"}, {"index", 1}}},
                     {"sky_fraction", 0.5},
                     {"frame_ms", 2.5},
                     {"overhead_ratio", 1.02},
                     {"bytes", 2048.0},
                     {"image_error", {{"against", "forward"}, {"psnr", nullptr}, {"identical", true}}}}}}};
      if (std::string(req.matches[1]) == "18") {
        // Footprint of each camera beside its requested bytes.
        samples["samples"][0]["footprint_bytes"] = 1024.0;
        samples["samples"][0]["reuse"] = 2.5;
        samples["samples"][1]["footprint_bytes"] = 512.0;
        samples["samples"][1]["reuse"] = 4.0;
      }
      if (std::string(req.matches[1]) == "16") {
        // The variant's samples: their image against the reference variant's.
        samples["samples"][0]["variant_error"] = {{"against", "visbuffer barycentrics=float32"}, {"psnr", 37.5},
                                                  {"identical", false}, {"max_abs", 20}, {"mean_abs", 0.5}};
        samples["samples"][1]["variant_error"] = {{"against", "visbuffer barycentrics=float32"}, {"psnr", nullptr},
                                                  {"identical", true}, {"max_abs", 0}, {"mean_abs", 0}};
      }
      reply(res, samples);
    });
    // A sample's trace: sample 404 does not exist.
    server_.Get(R"(/api/samples/(\d+)/trace)", [reply](const httplib::Request& req, httplib::Response& res) {
      int id = std::stoi(req.matches[1]);
      if (id == 404) {
        reply(res, {{"error", {{"code", "not_found"}, {"message", "no sample 404"}, {"field", nullptr}}}}, 404);
        return;
      }
      reply(res, {{"traceEvents", json::array({{{"name", "frame 0"}, {"ph", "X"}, {"pid", 1}, {"tid", 1},
                                                {"ts", 0}, {"dur", 1500}, {"args", json::object()}}})},
                  {"displayTimeUnit", "ms"},
                  {"metadata", {{"sample", id}}}});
    });
    server_.Get(R"(/api/samples/(\d+))", [reply](const httplib::Request& req, httplib::Response& res) {
      int id = std::stoi(req.matches[1]);
      double scale = id == 101 ? 1.0 : 0.5;
      reply(res, {{"id", id},
                  {"passes",
                   {{{"name", "gbuffer"},
                     {"counters",
                      {{{"resource", "material_maps.diffuse"}, {"access", "read"}, {"bytes", 2048 * scale}},
                       {{"resource", "gbuffer.normal"}, {"access", "write"}, {"bytes", 1024 * scale}}}}},
                    // the server's shape: "resources" with "name"; the first pass: "counters"
                    {{"name", "lighting"},
                     {"resources",
                      {{{"name", "gbuffer.normal"}, {"access", "read"}, {"bytes", 1048576 * scale}}}}}}}});
    });
    server_.Get("/api/compare", [reply](const httplib::Request& req, httplib::Response& res) {
      std::string runs = req.get_param_value("runs");
      if (runs.find("99") != std::string::npos)
        return reply(res, apiError("invalid_field", "run 99 not found", "runs[1]"), 400);
      auto c = [](double v0, double v1) {
        return json::array({{{"value", v0}, {"delta", 0.0}, {"ratio", 1.0}},
                            {{"value", v1}, {"delta", v1 - v0}, {"ratio", v1 / v0}}});
      };
      if (runs == "18,12") {
        // Footprint on the first run only: the second's footprint and reuse are null.
        auto first = [](double v0) {
          return json::array({{{"value", v0}, {"delta", 0.0}, {"ratio", 1.0}},
                              {{"value", nullptr}, {"delta", nullptr}, {"ratio", nullptr}}});
        };
        return reply(res, {{"runs", {footprintRunJson(18), runJson(12, "deferred", 320)}},
                           {"frame_ms", c(2.0, 1.5)},
                           {"total_bytes", c(4194304, 2097152)},
                           {"total_footprint_bytes", first(1048576)},
                           {"reuse", first(4.0)},
                           {"passes",
                            {{{"pass", "gbuffer"},
                              {"gpu_ms", c(0.8, 0.4)},
                              {"bytes", c(2097152, 1048576)},
                              {"footprint_bytes", first(524288)},
                              {"reuse", first(4.0)},
                              {"fragment_invocations", c(61234, 57600)}}}},
                           {"resources",
                            {{{"resource", "material_maps.diffuse"},
                              {"access", "read"},
                              {"count", c(57600, 57600)},
                              {"bytes", c(2097152, 1048576)},
                              {"footprint_bytes", first(262144)},
                              {"reuse", first(8.0)}}}}});
      }
      reply(res, {{"runs", {runJson(12, "deferred", 320), runJson(15, "visbuffer", 320)}},
                  {"frame_ms", c(2.0, 1.5)},
                  {"total_bytes", c(4194304, 2097152)},
                  {"passes",
                   {{{"pass", "gbuffer"},
                     {"gpu_ms", c(0.8, 0.4)},
                     {"bytes", c(2097152, 1048576)},
                     {"fragment_invocations", c(61234, 57600)}}}},
                  {"resources",
                   {{{"resource", "gbuffer.normal"},
                     {"access", "write"},
                     {"count", c(57600, 0)},
                     {"bytes", json::array({{{"value", 460800.0}}, {{"value", nullptr}}})}}}}});
    });
    // A 3x1 sphere heatmap of visbuffer against deferred: visbuffer
    // significantly lower in cell 0 (0.80), higher in cell 1 (1.25), not
    // significantly different in cell 2.
    server_.Get("/api/heatmap", [reply](const httplib::Request&, httplib::Response& res) {
      auto cell = [](double ratio, bool significant) {
        return json{
            {"value_a", 2.0}, {"value_b", 2.0 * ratio}, {"ratio", ratio}, {"significant", significant}};
      };
      json at = {{"row", 0}, {"column", 0}, {"value", 0.8}};
      reply(res, {{"scene", "atrium"},
                  {"width", 64},
                  {"height", 36},
                  {"device", "llvmpipe"},
                  {"renderer", "deferred"},
                  {"versus", "visbuffer"},
                  {"metric", "frame_ms"},
                  {"yaw", "mean"},
                  {"layout",
                   {{"layout", "sphere"},
                    {"columns", 3},
                    {"rows", 1},
                    {"latitudes_deg", {0.0}},
                    {"longitudes_deg", {-120.0, 0.0, 120.0}}}},
                  {"cells", {cell(0.8, true), cell(1.25, true), cell(1.01, false)}},
                  {"summary",
                   {{"cells", 3},
                    {"cells_measured", 3},
                    {"cells_empty", 0},
                    {"cells_incomplete", 0},
                    {"ratio",
                     {{"median", 1.01},
                      {"geometric_mean", 1.0},
                      {"min", at},
                      {"max", {{"row", 0}, {"column", 1}, {"value", 1.25}}}}},
                    {"significant", 2},
                    {"b_lower", 1},
                    {"b_higher", 1},
                    {"b_best_significant", at}}}});
    });
    server_.Get("/api/crossover", [reply](const httplib::Request& req, httplib::Response& res) {
      std::string capture = req.get_param_value("capture");
      if (capture != "7") return reply(res, apiError("not_found", "no capture " + capture), 404);
      std::string metric = req.has_param("metric") ? req.get_param_value("metric") : "bytes";
      reply(res, crossoverJson(metric));
    });
    server_.Get("/api/export", [this](const httplib::Request& req, httplib::Response& res) {
      {
        std::lock_guard lock(mutex_);
        lastExportQuery_ = req.params;
      }
      if (req.get_param_value("format") == "csv") {
        res.set_content("run_id,renderer,bytes\n12,deferred,3145728\n", "text/csv");
      } else {
        res.set_content(R"({"rows":[{"run_id":12,"renderer":"deferred"}]})", "application/json");
      }
    });
    server_.Get("/api/hosts",
                [reply](const httplib::Request&, httplib::Response& res) { reply(res, hostsJson()); });
    server_.Get("/api/health", [reply](const httplib::Request&, httplib::Response& res) {
      reply(res, {{"status", "ok"}, {"version", "0.1.0"}, {"api_version", 1}});
    });
    // Baselines and alerts: canned answers; the last body and query kept.
    auto baseline = [](int id, const std::string& status) {
      return json{{"id", id},
                  {"name", "deferred atrium"},
                  {"run", 12},
                  {"threshold", 0.03},
                  {"status", status},
                  {"configuration",
                   {{"renderer", "deferred"}, {"variant", "deferred"}, {"options", json::object()},
                    {"scene", "atrium"}, {"scene_params", json::object()}, {"width", 320}, {"height", 180},
                    {"device_id", 1}, {"device", "llvmpipe"}, {"counting", "exact"}}},
                  {"labels", {{"commit", "4f2a9c1"}}},
                  {"open_alerts", 2},
                  {"created_at", "2026-11-25T10:00:00.000Z"},
                  {"ended_at", nullptr},
                  {"replaced_by", nullptr}};
    };
    server_.Post("/api/baselines", [this, reply, baseline](const httplib::Request& req, httplib::Response& res) {
      json body = json::parse(req.body, nullptr, false);
      {
        std::lock_guard lock(mutex_);
        lastAlertsBody_ = body;
      }
      if (body.value("run", 0) == 99) return reply(res, apiError("not_found", "no run 99"), 404);
      json b = baseline(3, "active");
      b["replaced"] = 2;
      reply(res, b, 201);
    });
    server_.Get("/api/baselines", [this, reply, baseline](const httplib::Request& req, httplib::Response& res) {
      {
        std::lock_guard lock(mutex_);
        lastAlertsQuery_ = req.params;
      }
      json list = json::array({baseline(3, "active")});
      if (req.get_param_value("all") == "true") list.push_back(baseline(2, "replaced"));
      reply(res, {{"baselines", list}});
    });
    server_.Delete(R"(/api/baselines/(\d+))", [reply, baseline](const httplib::Request& req, httplib::Response& res) {
      int id = std::stoi(req.matches[1]);
      if (id == 99) return reply(res, apiError("not_found", "no baseline 99"), 404);
      reply(res, baseline(id, "removed"));
    });
    server_.Get("/api/alerts", [this, reply](const httplib::Request& req, httplib::Response& res) {
      {
        std::lock_guard lock(mutex_);
        lastAlertsQuery_ = req.params;
      }
      json time = {{"id", 5}, {"baseline", 3}, {"run", 15}, {"baseline_run", 12}, {"kind", "time"},
                   {"metric", "frame"}, {"verdict", "slower"}, {"ratio", 1.25}, {"interval", {1.18, 1.31}},
                   {"p_value", 0.00016}, {"cliffs_delta", 1.0}, {"value_a", 1.834}, {"value_b", 2.2925},
                   {"details", json::object()}, {"status", "open"}, {"created_at", "2026-11-25T10:05:00.000Z"}};
      json counts = {{"id", 6}, {"baseline", 3}, {"run", 15}, {"baseline_run", 12}, {"kind", "counts"},
                     {"metric", "counts"}, {"verdict", "changed"}, {"ratio", 2.0}, {"interval", nullptr},
                     {"p_value", nullptr}, {"cliffs_delta", nullptr}, {"value_a", 3145728.0}, {"value_b", 6291456.0},
                     {"details", {{"lines", 12}, {"changed", 3}, {"changes", json::array()}}}, {"status", "open"},
                     {"created_at", "2026-11-25T10:05:00.000Z"}};
      reply(res, {{"alerts", {counts, time}},
                  {"next_cursor", nullptr},
                  {"counts", {{"open", 2}, {"acknowledged", 0}, {"invalid", 0}, {"fixed", 0}}}});
    });
    server_.Patch(R"(/api/alerts/(\d+))", [this, reply](const httplib::Request& req, httplib::Response& res) {
      json body = json::parse(req.body, nullptr, false);
      {
        std::lock_guard lock(mutex_);
        lastAlertsBody_ = body;
      }
      int id = std::stoi(req.matches[1]);
      if (id == 99) return reply(res, apiError("not_found", "no alert 99"), 404);
      reply(res, {{"id", id}, {"status", body.value("status", "")}});
    });
    server_.Get("/api/broken", [](const httplib::Request&, httplib::Response& res) {
      res.status = 502;
      res.set_content("<html>bad gateway</html>\n", "text/html");
    });

    if (port == 0) {
      port_ = server_.bind_to_any_port("127.0.0.1");
    } else {
      for (int i = 0; i < 200 && !server_.bind_to_port("127.0.0.1", port); ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      port_ = port;
    }
    thread_ = std::thread([this] { server_.listen_after_bind(); });
    for (int i = 0; i < 500 && !server_.is_running(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ~FakeTallyd() {
    server_.stop();
    thread_.join();
  }

  int port() const { return port_; }
  std::string url() const { return "http://127.0.0.1:" + std::to_string(port_); }

  std::string lastSpec() {
    std::lock_guard lock(mutex_);
    return lastSpec_;
  }
  int polls(int captureId) {
    std::lock_guard lock(mutex_);
    return polls_[captureId];
  }
  std::string lastIdempotencyKey() {
    std::lock_guard lock(mutex_);
    return lastIdempotencyKey_;
  }
  std::string lastAuthorization() {
    std::lock_guard lock(mutex_);
    return lastAuthorization_;
  }
  httplib::Params lastRunsQuery() {
    std::lock_guard lock(mutex_);
    return lastRunsQuery_;
  }
  json lastAlertsBody() {
    std::lock_guard lock(mutex_);
    return lastAlertsBody_;
  }
  httplib::Params lastAlertsQuery() {
    std::lock_guard lock(mutex_);
    return lastAlertsQuery_;
  }
  httplib::Params lastExportQuery() {
    std::lock_guard lock(mutex_);
    return lastExportQuery_;
  }

 private:
  httplib::Server server_;
  std::thread thread_;
  int port_ = 0;
  std::mutex mutex_;
  std::map<int, int> polls_;  // GETs per capture id
  std::string lastSpec_, lastIdempotencyKey_, lastAuthorization_;
  httplib::Params lastRunsQuery_, lastExportQuery_, lastAlertsQuery_;
  json lastAlertsBody_;
};

// A loopback port with nothing listening: bound, then closed.
inline int deadPort() {
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof(addr);
  ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr));
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ::close(fd);
  return ntohs(addr.sin_port);
}

}  // namespace tally::client::test
