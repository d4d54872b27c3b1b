#include "service/service.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <system_error>

#include "capture/spec.hpp"
#include "service/accuracy.hpp"
#include "service/alerts.hpp"
#include "service/crossover.hpp"
#include "service/heatmap.hpp"
#include "service/repeats.hpp"
#include "service/routes.hpp"
#include "service/run_significance.hpp"
#include "service/store_health.hpp"
#include "service/trace.hpp"
#include "sweeps/sweep.hpp"

namespace tally::service {
namespace fs = std::filesystem;
using api::Request;
using api::Response;
using nlohmann::json;

namespace detail {

// ---- query parameters -----------------------------------------------------------

std::optional<int64_t> queryInt(const Request& req, const std::string& key, int64_t low, int64_t high) {
  const std::string* v = req.queryValue(key);
  if (!v) return std::nullopt;
  int64_t n = 0;
  size_t used = 0;
  try {
    n = std::stoll(*v, &used, 10);
  } catch (const std::exception&) {
    used = 0;
  }
  if (v->empty() || used != v->size() || !(std::isdigit(static_cast<unsigned char>((*v)[0])) || (*v)[0] == '-') ||
      n < low || n > high) {
    invalid(key, "must be an integer between " + std::to_string(low) + " and " + std::to_string(high));
  }
  return n;
}

std::optional<std::string> queryString(const Request& req, const std::string& key, size_t maxLength) {
  const std::string* v = req.queryValue(key);
  if (!v) return std::nullopt;
  if (v->empty() || v->size() > maxLength) {
    invalid(key, "must be 1 to " + std::to_string(maxLength) + " characters");
  }
  return *v;
}

// A number in [low, high] (exclusive ends where asked): "confidence=0.99".
std::optional<double> queryDouble(const Request& req, const std::string& key, double low, double high,
                                  bool openLow, bool openHigh) {
  const std::string* v = req.queryValue(key);
  if (!v) return std::nullopt;
  double n = 0;
  size_t used = 0;
  try {
    n = std::stod(*v, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  bool inRange = std::isfinite(n) && (openLow ? n > low : n >= low) && (openHigh ? n < high : n <= high);
  if (v->empty() || used != v->size() || !inRange) {
    std::ostringstream range;
    range << (openLow ? "(" : "[") << low << ", " << high << (openHigh ? ")" : "]");
    invalid(key, "must be a number in " + range.str() + ", got '" + v->substr(0, 32) + "'");
  }
  return n;
}

std::optional<bool> queryBool(const Request& req, const std::string& key) {
  const std::string* v = req.queryValue(key);
  if (!v) return std::nullopt;
  if (*v == "true" || *v == "1") return true;
  if (*v == "false" || *v == "0") return false;
  invalid(key, "must be true or false");
}

int64_t pathId(const Request& req) {
  const std::string& v = req.param("id");
  int64_t n = 0;
  size_t used = 0;
  try {
    n = std::stoll(v, &used, 10);
  } catch (const std::exception&) {
    used = 0;
  }
  if (v.empty() || used != v.size() || !std::isdigit(static_cast<unsigned char>(v[0])) || n < 1) {
    invalid("id", "must be a positive integer");
  }
  return n;
}

store::Page queryPage(const Request& req) {
  store::Page page;
  page.limit = static_cast<int>(queryInt(req, "limit", 1, 1000).value_or(100));
  if (auto c = queryString(req, "cursor", 64)) {
    if (!store::decodeCursor(*c)) invalid("cursor", "not a cursor from a previous page");
    page.cursor = *c;
  }
  return page;
}

void allowOnly(const Request& req, const std::set<std::string>& keys) {
  for (const auto& [key, value] : req.query) {
    if (!keys.count(key)) {
      std::string known;
      for (const auto& k : keys) known += (known.empty() ? "" : ", ") + k;
      invalid(key, "unknown query parameter (expected " + (known.empty() ? std::string("none") : known) + ")");
    }
  }
}

// A creation-time bound: a prefix of the stored UTC ISO-8601 form
// 2026-11-21T06:30:00.123Z at a field boundary (a date, minutes, seconds,
// milliseconds, or all of it), so that text comparison orders it correctly.
std::optional<std::string> queryTime(const Request& req, const std::string& key) {
  const std::string* v = req.queryValue(key);
  if (!v) return std::nullopt;
  static const std::string kPattern = "0000-00-00T00:00:00.000Z";  // '0': a digit
  bool boundary = v->size() == 10 || v->size() == 16 || v->size() == 19 || v->size() == 23 || v->size() == 24;
  bool matches = boundary;
  for (size_t i = 0; matches && i < v->size(); ++i) {
    char c = (*v)[i];
    matches = kPattern[i] == '0' ? std::isdigit(static_cast<unsigned char>(c)) != 0 : c == kPattern[i];
  }
  if (!matches) invalid(key, "must be a UTC date or time: 2026-11-21, 2026-11-21T06:30 or 2026-11-21T06:30:00.123Z");
  return *v;
}

store::RunFilter queryFilter(const Request& req) {
  store::RunFilter f;
  f.renderer = queryString(req, "renderer");
  f.variant = queryString(req, "variant");
  f.scene = queryString(req, "scene");
  if (auto w = queryInt(req, "width", 1, kMaxDimension)) f.width = static_cast<int>(*w);
  if (auto h = queryInt(req, "height", 1, kMaxDimension)) f.height = static_cast<int>(*h);
  if (const std::string* d = req.queryValue("device")) {
    // A device id, or its exact name.
    bool numeric = !d->empty() && d->find_first_not_of("0123456789") == std::string::npos;
    if (numeric) {
      f.deviceId = queryInt(req, "device", 1, INT64_MAX);
    } else {
      f.deviceName = queryString(req, "device");
    }
  }
  f.jobId = queryInt(req, "capture", 1, INT64_MAX);
  f.host = queryString(req, "host");
  if (auto label = queryString(req, "label", 512)) {
    // NAME=VALUE: the runs of captures that carry that label.
    size_t eq = label->find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == label->size()) {
      invalid("label", "must be NAME=VALUE (commit=4f2a9c1)");
    }
    f.labels.emplace_back(label->substr(0, eq), label->substr(eq + 1));
  }
  f.createdSince = queryTime(req, "since");
  f.createdUntil = queryTime(req, "until");
  return f;
}

// ---- JSON ------------------------------------------------------------------------

// Reuse: requested bytes over the footprint of the same lines (how many
// times each distinct byte was asked for); null without a footprint or at 0.
json reuseJson(std::optional<double> requested, std::optional<double> footprint) {
  if (!footprint || *footprint <= 0) return nullptr;
  return requested.value_or(0) / *footprint;
}

json jobJson(const store::Job& j) {
  return {{"id", j.id},
          {"status", store::toString(j.status)},
          {"spec", j.spec},
          {"progress", {{"done", j.progressDone}, {"total", j.progressTotal}, {"current", opt(j.progressCurrent)}}},
          {"error", opt(j.error)},
          {"attempts", j.attempts},
          {"max_attempts", j.maxAttempts},
          {"attempt_errors", j.attemptErrors.is_array() ? j.attemptErrors : json::array()},
          {"host", opt(j.host)},
          {"lease_expires_at", j.leaseExpiresMs ? json(store::isoTimeFromMs(*j.leaseExpiresMs)) : json(nullptr)},
          {"device", j.deviceRequirement},
          {"waiting", nullptr},
          {"created_at", j.createdAt},
          {"started_at", opt(j.startedAt)},
          {"finished_at", opt(j.finishedAt)}};
}

json hostJson(const store::Host& h) {
  json device = nullptr;
  if (h.info.device.is_object()) {
    const json& d = h.info.device;
    device = {{"name", d.value("name", "")},
              {"vendor", store::vendorName(d.value("vendorID", ""))},
              {"vendor_id", d.value("vendorID", "")},
              {"driver", d.value("driverInfo", "")},
              {"api_version", d.value("apiVersion", "")},
              {"type", d.value("type", "")},
              {"features", d.contains("features") ? d["features"] : json::object()}};
  }
  return {{"name", h.info.name},
          {"role", h.info.role},
          {"device", device},
          {"device_override", opt(h.info.deviceOverride)},
          {"tally_version", h.info.tallyVersion},
          {"tally_commit", h.info.tallyCommit},
          {"started_at", h.startedAt},
          {"last_heartbeat", h.lastHeartbeat},
          {"seconds_since_heartbeat", h.secondsSinceHeartbeat},
          {"alive", h.alive},
          {"jobs_done", h.jobsDone},
          {"jobs_failed", h.jobsFailed},
          {"current_job", opt(h.currentJob)}};
}

// Why nobody runs a queued job, from the hosts: none alive; none alive whose
// device meets its requirement (each one's reason); or every one that could
// is busy. Null when a free worker can take it (it will, at its next poll).
json waitingReason(const store::Job& job, const std::vector<store::Host>& hosts, int64_t staleAfterMs) {
  if (job.status != store::JobStatus::Queued) return nullptr;
  std::vector<const store::Host*> alive;
  for (const auto& h : hosts) {
    if (h.alive) alive.push_back(&h);
  }
  if (alive.empty()) {
    return "no live worker: " + std::to_string(hosts.size()) + " host(s) registered, none with a heartbeat in the last " +
           std::to_string(staleAfterMs / 1000) + " s";
  }
  std::optional<store::DeviceRequirement> requirement;
  if (!job.deviceRequirement.is_null()) {
    auto parsed = store::deviceRequirementFromJson(job.deviceRequirement);
    if (parsed) requirement = *parsed;
  }
  std::vector<const store::Host*> able;
  std::string mismatches;
  for (const auto* h : alive) {
    std::string why = requirement ? store::deviceMismatch(*requirement, h->info.device) : "";
    if (why.empty()) {
      able.push_back(h);
    } else {
      mismatches += (mismatches.empty() ? "" : "; ") + h->info.name + ": " + why;
    }
  }
  if (able.empty()) {
    return "no live worker has a device matching " + job.deviceRequirement.dump() + " (" + mismatches + ")";
  }
  std::string busy;
  for (const auto* h : able) {
    if (!h->currentJob) return nullptr;
    busy += (busy.empty() ? "" : ", ") + h->info.name + " (capture " + std::to_string(*h->currentJob) + ")";
  }
  return "waiting for a " + std::string(requirement ? "matching " : "") + "worker to finish: " + busy;
}

json runRowJson(const store::RunRow& r) {
  return {{"id", r.id},
          {"capture", r.jobId},
          {"device_id", r.deviceId},
          {"device", r.deviceName},
          {"renderer", r.renderer},
          {"options", r.options},
          {"variant", r.variant},
          {"scene", r.scene},
          {"scene_params", r.sceneParams},
          {"width", r.width},
          {"height", r.height},
          {"counting", r.counting},
          {"footprint_block_bytes", opt(r.footprintBlockBytes)},
          {"lights", r.lights},
          {"render_target_bytes", opt(r.renderTargetBytes)},
          {"notes", r.notes},
          {"created_at", r.createdAt},
          {"tally_version", opt(r.tallyVersion)},
          {"tally_commit", opt(r.tallyCommit)},
          {"host", opt(r.host)},
          {"labels", r.labels},
          {"sample_count", r.sampleCount},
          {"mean_frame_ms", opt(r.meanFrameMs)},
          {"mean_bytes", opt(r.meanBytes)},
          {"mean_footprint_bytes", opt(r.meanFootprintBytes)},
          {"mean_reuse", reuseJson(r.meanFootprintRequestedBytes, r.meanFootprintBytes)},
          {"mean_frame_ms_instrumented", opt(r.meanFrameMsInstrumented)},
          {"mean_overhead_ratio", opt(r.meanOverheadRatio)},
          {"image_error", r.imageCompared == 0 ? json(nullptr)
                                                : json{{"samples", r.imageCompared},
                                                       {"identical", r.imageIdentical},
                                                       {"mean_psnr", opt(r.meanPsnr)},
                                                       {"min_psnr", opt(r.minPsnr)}}}};
}

json deviceJson(const store::Device& d) {
  return {{"id", d.id},           {"name", d.name},         {"vendor", d.vendor}, {"driver", d.driver},
          {"api_version", d.apiVersion}, {"features", d.features}, {"info", d.info}};
}

json sweepRowJson(const store::SweepRow& s) {
  return {{"id", s.id},
          {"job_id", s.jobId},
          {"name", s.name},
          {"created_at", s.createdAt},
          {"device", deviceJson(s.device)},
          {"parameters", s.parameters},
          {"threshold", s.threshold},
          {"fails_at", s.failsAt},
          {"point_count", s.pointCount}};
}

json sampleRowJson(const store::SampleRow& s) {
  json j = {{"id", s.id},
            {"run", s.runId},
            {"camera_index", s.cameraIndex},
            {"camera", s.camera},
            {"sky_fraction", opt(s.skyFraction)},
            {"sky_fraction_estimate", opt(s.skyFractionEstimate)},
            {"frames", opt(s.frames)},
            {"frame_ms", s.frameMs},
            {"frame_ms_spread", s.frameMsSpread},
            {"frame_ms_instrumented", opt(s.frameMsInstrumented)},
            {"overhead_ratio", opt(s.overheadRatio)},
            {"bytes", s.bytes},
            {"bytes_read", s.bytesRead},
            {"bytes_written", s.bytesWritten},
            {"footprint_bytes", opt(s.footprintBytes)},
            {"reuse", reuseJson(s.footprintRequestedBytes, s.footprintBytes)},
            {"image_error", nullptr},
            {"variant_error", nullptr},
            {"extras", s.extras},
            {"screenshot", s.hasScreenshot ? json("/api/samples/" + std::to_string(s.id) + "/screenshot.png")
                                           : json(nullptr)}};
  if (s.imageError) {
    j["image_error"] = {{"against", s.imageError->against},
                        {"identical", s.imageError->identical},
                        {"psnr", opt(s.imageError->psnr)},
                        {"max_abs", s.imageError->maxAbs},
                        {"mean_abs", s.imageError->meanAbs}};
  }
  if (s.variantError) {
    j["variant_error"] = {{"against", s.variantError->against},
                          {"identical", s.variantError->identical},
                          {"psnr", opt(s.variantError->psnr)},
                          {"max_abs", s.variantError->maxAbs},
                          {"mean_abs", s.variantError->meanAbs}};
  }
  return j;
}

json passJson(const store::Pass& p) {
  json resources = json::array();
  double bytes = 0;
  std::optional<double> footprint, footprintRequested;  // over the lines that have a footprint
  for (const auto& c : p.counters) {
    resources.push_back({{"name", c.resource},
                         {"kind", opt(c.kind)},
                         {"format", opt(c.format)},
                         {"access", c.access},
                         {"count", c.count},
                         {"bytes", c.bytes},
                         {"footprint_bytes", opt(c.footprintBytes)},
                         {"reuse", reuseJson(c.bytes, c.footprintBytes)},
                         {"count_spread", c.countSpread},
                         {"source", c.source}});
    bytes += c.bytes;
    if (c.footprintBytes) {
      footprint = footprint.value_or(0) + *c.footprintBytes;
      footprintRequested = footprintRequested.value_or(0) + c.bytes;
    }
  }
  return {{"name", p.name},
          {"gpu_ms", p.gpuMs},
          {"gpu_ms_spread", p.gpuMsSpread},
          {"gpu_ms_instrumented", opt(p.gpuMsInstrumented)},
          {"overhead_ratio", opt(p.overheadRatio)},
          {"fragment_invocations", opt(p.fragmentInvocations)},
          {"fragment_invocations_statistic", opt(p.fragmentInvocationsStatistic)},
          {"compute_invocations", opt(p.computeInvocations)},
          {"compute_invocations_statistic", opt(p.computeInvocationsStatistic)},
          {"bytes", bytes},
          {"footprint_bytes", opt(footprint)},
          {"reuse", reuseJson(footprintRequested, footprint)},
          {"resources", resources}};
}

json comparedJson(const std::vector<store::Compared>& values) {
  json out = json::array();
  for (const auto& c : values) out.push_back({{"value", opt(c.value)}, {"delta", opt(c.delta)}, {"ratio", opt(c.ratio)}});
  return out;
}

json comparisonJson(const store::Comparison& c) {
  json runs = json::array(), passes = json::array(), resources = json::array();
  for (const auto& r : c.runs) runs.push_back(runRowJson(r));
  for (const auto& p : c.passes) {
    passes.push_back({{"pass", p.pass},
                      {"gpu_ms", comparedJson(p.gpuMs)},
                      {"bytes", comparedJson(p.bytes)},
                      {"footprint_bytes", comparedJson(p.footprintBytes)},
                      {"reuse", comparedJson(p.reuse)},
                      {"fragment_invocations", comparedJson(p.fragmentInvocations)}});
  }
  for (const auto& r : c.resources) {
    resources.push_back({{"resource", r.resource},
                         {"access", r.access},
                         {"count", comparedJson(r.count)},
                         {"bytes", comparedJson(r.bytes)},
                         {"footprint_bytes", comparedJson(r.footprintBytes)},
                         {"reuse", comparedJson(r.reuse)}});
  }
  return {{"runs", runs},
          {"frame_ms", comparedJson(c.frameMs)},
          {"total_bytes", comparedJson(c.totalBytes)},
          {"total_footprint_bytes", comparedJson(c.totalFootprintBytes)},
          {"reuse", comparedJson(c.reuse)},
          {"passes", passes},
          {"resources", resources}};
}

// ---- the reader ---------------------------------------------------------------------

store::Store& reader(const ServiceContext& ctx) {
  thread_local std::string path;
  thread_local std::unique_ptr<store::Store> store;
  if (!store || path != ctx.dbPath) {
    store.reset();
    auto opened = store::Store::open(ctx.dbPath, {.readOnly = true});
    if (!opened) {
      // A store that cannot be opened is a fault of the store, named or not.
      store::Fault fault = store::lastFault();
      if (fault == store::Fault::kNone) {
        fault = store::isPostgresUrl(ctx.dbPath) ? store::Fault::kUnreachable : store::Fault::kDamaged;
      }
      throw StoreUnavailable(fault, "cannot open a reader: " + opened.error());
    }
    store = std::move(opened).value();
    path = ctx.dbPath;
  }
  return *store;
}

// ---- capture specs -------------------------------------------------------------------

bool under(const fs::path& file, const fs::path& folder) {
  auto f = file.begin(), d = folder.begin();
  for (; d != folder.end(); ++d, ++f) {
    if (d->empty()) continue;  // a trailing separator
    if (f == file.end() || *f != *d) return false;
  }
  return true;
}

// Resolves a glTF path against the scene folders: relative paths are looked
// up in each folder, absolute ones must lie in one; symlinks are followed
// before the check, so a link cannot escape. Returns the canonical path.
std::string resolveGltf(const ServiceOptions& options, const std::string& given, const std::string& field) {
  if (options.sceneFolders.empty()) invalid(field, "glTF scenes are not enabled (the daemon has no --scenes folder)");
  if (given.size() > 4096 || given.find('\0') != std::string::npos) invalid(field, "not a valid path");
  fs::path p(given);
  for (const auto& part : p) {
    if (part == "..") invalid(field, "must not contain '..'");
  }
  std::error_code ec;
  for (const auto& folder : options.sceneFolders) {
    fs::path root = fs::canonical(folder, ec);
    if (ec) continue;
    fs::path candidate = p.is_absolute() ? p : root / p;
    fs::path real = fs::canonical(candidate, ec);
    if (ec) continue;
    if (!under(real, root)) {
      if (p.is_absolute()) continue;
      invalid(field, "resolves outside the scene folders");
    }
    if (!fs::is_regular_file(real, ec)) invalid(field, "not a file");
    auto ext = real.extension().string();
    if (ext != ".gltf" && ext != ".glb") invalid(field, "must be a .gltf or .glb file");
    return real.string();
  }
  invalid(field, "no such file under the scene folders");
}

// An application or a replay under the Vulkan layer: a program runs on this
// host, so only where the daemon allows it, for the application token, and
// only as the policy lets it (capture/application_policy.hpp). Paths are the
// host's: a program by name (looked up on the daemon's $PATH) or absolute, a
// replay file absolute, each resolving inside an --application-root.
json validateApplicationSpec(const ServiceContext& ctx, const json& body, api::Principal principal) {
  const std::string key = body.contains("application") ? "application" : "replay";
  if (!ctx.options.allowApplications) {
    invalid(key, "this daemon does not run applications (tallyd serve --allow-applications enables them)");
  }
  if (principal != api::Principal::kApplication) {
    throw RequestError(
        403, api::code::kForbidden,
        "running an application needs the application token (the token file's application= line); "
        "this token may capture but not run programs",
        "Authorization");
  }
  auto parsed = capture::parseConfinedApplicationSpec(body, ctx.options.applicationPolicy);
  if (!parsed) throw RequestError(400, api::code::kInvalidField, parsed.error(), parsed.failure().field());
  return body;
}

json validateContent(const ServiceContext& ctx, const json& body, api::Principal principal);

// The spec's "device" picks the hosts that may run it (docs/fleet.md); the
// rest is the capture, sweep or application spec, checked by its parser.
json validateSpec(const ServiceContext& ctx, const json& body, api::Principal principal) {
  if (!body.is_object()) throw RequestError(400, api::code::kBadJson, "the body must be a capture spec (a JSON object)");
  if (!body.contains("device")) return validateContent(ctx, body, principal);
  auto requirement = store::parseDeviceRequirement(body);
  if (!requirement)
    throw RequestError(400, api::code::kInvalidField, requirement.error(), requirement.failure().field());
  json content = body;
  content.erase("device");
  json stored = validateContent(ctx, content, principal);
  stored["device"] = body["device"];
  return stored;
}

json validateContent(const ServiceContext& ctx, const json& body, api::Principal principal) {
  // {"application": ...} or {"replay": ...}: its parser names any field of a
  // capture matrix or a sweep beside it.
  if (capture::isApplicationSpec(body)) return validateApplicationSpec(ctx, body, principal);
  // A stability sweep ({"sweep": NAME, ...}) is checked by its own parser; its
  // limits on points and resolution are the sweep's (sweeps/sweep.hpp).
  if (sweeps::isSweepSpec(body)) {
    auto sweep = sweeps::parseSweepSpec(body, ctx.rendererNames);
    if (!sweep) throw RequestError(400, api::code::kInvalidField, sweep.error(), sweep.failure().field());
    return body;
  }
  auto parsed = capture::parseCaptureSpec(body, ctx.rendererNames);
  if (!parsed) {
    throw RequestError(400, api::code::kInvalidField, parsed.error(), parsed.failure().field());
  }
  const auto& spec = *parsed;
  const auto& options = ctx.options;
  for (size_t i = 0; i < spec.resolutions.size(); ++i) {
    uint64_t pixels = uint64_t(spec.resolutions[i].width) * spec.resolutions[i].height;
    if (pixels > options.maxPixels) {
      invalid("resolutions[" + std::to_string(i) + "]",
              "at most " + std::to_string(options.maxPixels) + " pixels on this server, got " + std::to_string(pixels));
    }
  }
  if (spec.frames > options.maxFrames) {
    invalid("frames", "at most " + std::to_string(options.maxFrames) + " on this server");
  }
  // A heatmap counts every pose it may place (cells x yaws).
  size_t cameras = spec.camerasPerScene();
  if (spec.sampleCount(cameras) > options.maxMatrix) {
    invalid("spec", "the matrix (renderers x scenes x resolutions x cameras) has " +
                        std::to_string(spec.sampleCount(cameras)) + " samples; at most " +
                        std::to_string(options.maxMatrix) + " on this server");
  }
  // What it renders: samples x frames x pixels (capture::CaptureSpec::cost).
  if (uint64_t cost = spec.cost(); cost > options.maxCost) {
    invalid("spec", "the capture's cost (samples x frames x pixels) is " + std::to_string(cost) +
                        " pixel-frames; at most " + std::to_string(options.maxCost) +
                        " on this server (max_cost; fewer frames, resolutions or cameras)");
  }
  // glTF paths are resolved (a stat per scene folder; the file is loaded by
  // the capture), and two spellings of one file are one scene.
  json stored = body;
  if (stored.contains("scenes")) {
    std::vector<std::pair<std::string, size_t>> files;  // resolved path, index
    for (size_t i = 0; i < stored["scenes"].size(); ++i) {
      json& s = stored["scenes"][i];
      if (s.is_object() && s.contains("gltf")) {
        std::string field = "scenes[" + std::to_string(i) + "].gltf";
        s["gltf"] = resolveGltf(options, s["gltf"].get<std::string>(), field);
        for (const auto& [path, k] : files) {
          if (path == s["gltf"] &&
              stored["scenes"][k].value("max_texture_size", json()) == s.value("max_texture_size", json())) {
            invalid("scenes[" + std::to_string(i) + "]",
                    "a duplicate of scenes[" + std::to_string(k) + "] (each entry must differ)");
          }
        }
        files.emplace_back(s["gltf"].get<std::string>(), i);
      }
    }
  }
  return stored;
}

// ---- handlers ------------------------------------------------------------------------

int retryAfterSeconds(store::Fault fault) {
  switch (fault) {
    case store::Fault::kBusy: return 1;
    case store::Fault::kFull:
    case store::Fault::kIoError:
    case store::Fault::kReadOnly:
    case store::Fault::kUnreachable: return 5;
    default: return 60;  // damage: not before it is repaired
  }
}

void requireWritable(const ServiceContext& ctx) {
  if (!ctx.health) return;
  StoreHealth::State state = ctx.health->state();
  if (state.fault == store::Fault::kDamaged) throw StoreUnavailable(state.fault, state.reason);
}

Response wrap(ServiceContext& ctx, const std::function<Response()>& handler) {
  auto log = [&](const std::string& line) {
    if (ctx.log) {
      ctx.log(line);
    } else {
      std::fprintf(stderr, "%s\n", line.c_str());
    }
  };
  try {
    return handler();
  } catch (const RequestError& e) {
    return api::errorResponse(e.status, e.code, e.what(), e.field);
  } catch (const StoreUnavailable& e) {
    // The store's own fault, named: 503, never a bare 500.
    std::string reason = store::describe(e.fault);
    if (ctx.health) {
      ctx.health->noteFault(e.fault, e.what());
      StoreHealth::State state = ctx.health->state();
      if (state.fault == e.fault && !state.reason.empty()) reason = state.reason;
    } else {
      log(std::string("service: store ") + store::toString(e.fault) + ": " + e.what());
    }
    Response r = api::errorResponse(503, api::code::kStoreUnavailable, reason, "store");
    r.headers.emplace_back("Retry-After", std::to_string(retryAfterSeconds(e.fault)));
    return r;
  } catch (const std::exception& e) {
    log(std::string("service: ") + e.what());
    return api::errorResponse(500, api::code::kInternal, "internal error");
  }
}

Response postCapture(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  json spec = validateSpec(ctx, req.body, req.principal);
  std::optional<std::string> key;
  if (!req.idempotencyKey.empty()) key = req.idempotencyKey;
  store::QueueLimits limits;
  limits.client = req.client;
  limits.maxQueued = ctx.options.maxQueued;
  limits.maxQueuedPerClient = ctx.options.maxQueuedPerClient;
  requireWritable(ctx);
  auto created = check(ctx.writer->createJob(spec, key, ctx.options.maxAttempts, limits));
  if (ctx.health) ctx.health->noteWriteOk();
  if (!created.refused.empty()) {
    if (ctx.onQueueLimited) ctx.onQueueLimited(created.refused);
    const bool mine = created.refused == "client";
    Response r = api::errorResponse(
        429, api::code::kTooManyRequests,
        (mine ? "this client has " : "the queue holds ") + std::to_string(created.queued) +
            " queued captures, the limit " + (mine ? "per client" : "of this server") + " (" +
            (mine ? "max_queued_per_client " + std::to_string(ctx.options.maxQueuedPerClient)
                  : "max_queued " + std::to_string(ctx.options.maxQueued)) +
            "); try again once some have run");
    r.headers.emplace_back("Retry-After", std::to_string(ctx.options.retryAfterSeconds));
    return r;
  }
  if (created.conflict) {
    throw RequestError(409, api::code::kConflict,
                       "Idempotency-Key was used before with a different spec (capture " +
                           std::to_string(created.job.id) + ")",
                       "Idempotency-Key");
  }
  if (created.created && ctx.onJobQueued) ctx.onJobQueued();
  Response r = Response::ok({{"id", created.job.id}, {"status", store::toString(created.job.status)}}, 202);
  r.headers.emplace_back("Location", "/api/captures/" + std::to_string(created.job.id));
  return r;
}

Response listCaptures(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"status", "limit", "cursor"});
  std::optional<store::JobStatus> status;
  if (auto s = queryString(req, "status", 32)) {
    status = store::parseJobStatus(*s);
    if (!status) invalid("status", "must be queued, running, done, failed or cancelled");
  }
  auto& store = reader(ctx);
  auto page = check(store.listJobs(status, queryPage(req)));
  std::optional<std::vector<store::Host>> hosts;
  json jobs = json::array();
  for (const auto& j : page.jobs) {
    json out = jobJson(j);
    if (j.status == store::JobStatus::Queued) {
      if (!hosts) hosts = check(store.listHosts(ctx.options.staleAfterMs));
      out["waiting"] = waitingReason(j, *hosts, ctx.options.staleAfterMs);
    }
    jobs.push_back(std::move(out));
  }
  return Response::ok({{"captures", jobs}, {"next_cursor", page.nextCursor.empty() ? json(nullptr) : json(page.nextCursor)}});
}

Response getCapture(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto& store = reader(ctx);
  auto job = check(store.getJob(id));
  if (!job) return api::notFound("no capture " + std::to_string(id));
  json j = jobJson(*job);
  j["sweeps"] = check(store.jobSweepIds(id));  // a finished sweep job's sweep
  if (job->status == store::JobStatus::Queued) {
    j["waiting"] = waitingReason(*job, check(store.listHosts(ctx.options.staleAfterMs)), ctx.options.staleAfterMs);
  }
  return Response::ok(j);
}

Response cancelCapture(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto before = check(ctx.writer->getJob(id));
  if (!before) return api::notFound("no capture " + std::to_string(id));
  auto finished = [](store::JobStatus s) { return s != store::JobStatus::Queued && s != store::JobStatus::Running; };
  if (!finished(before->status)) requireWritable(ctx);
  auto job = finished(before->status) ? before : check(ctx.writer->cancelJob(id));
  if (!finished(before->status) && ctx.health) ctx.health->noteWriteOk();
  if (!job) return api::notFound("no capture " + std::to_string(id));
  // Finished before (a second cancel included) or meanwhile: nothing to cancel.
  if (finished(before->status) || job->status != store::JobStatus::Cancelled) {
    return api::conflict("capture " + std::to_string(id) + " has already finished (" + store::toString(job->status) +
                         ")");
  }
  // A running job is reported by the worker when it stops the child.
  if (before->status == store::JobStatus::Queued && ctx.onQueuedJobCancelled) ctx.onQueuedJobCancelled(id);
  return Response::ok(jobJson(*job));
}

Response listRuns(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"renderer", "variant", "scene", "width", "height", "device", "capture", "host", "label", "since", "until", "limit",
                  "cursor"});
  auto filter = queryFilter(req);
  auto page = check(reader(ctx).listRuns(filter, queryPage(req)));
  json runs = json::array();
  for (const auto& r : page.runs) runs.push_back(runRowJson(r));
  return Response::ok({{"runs", runs}, {"next_cursor", page.nextCursor.empty() ? json(nullptr) : json(page.nextCursor)}});
}

// Non-exact runs against their exact reference (service/accuracy.hpp).
Response accuracy(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"renderer", "variant", "scene", "width", "height", "device", "capture", "since", "until"});
  return Response::ok(check(accuracyRows(reader(ctx), queryFilter(req))));
}

// Groups of identical-configuration runs and their agreement (service/repeats.hpp).
Response repeats(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"renderer", "variant", "scene", "width", "height", "device", "capture", "since", "until"});
  return Response::ok(check(repeatGroups(reader(ctx), queryFilter(req))));
}

Response getRun(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto run = check(reader(ctx).getRun(id));
  if (!run) return api::notFound("no run " + std::to_string(id));
  json j = runRowJson(run->row);
  j["device_info"] = deviceJson(run->device);
  json resources = json::array();
  for (const auto& r : run->resources) {
    resources.push_back({{"name", r.name},
                         {"kind", r.kind},
                         {"format", opt(r.format)},
                         {"element_bytes", opt(r.elementBytes)},
                         {"width", opt(r.width)},
                         {"height", opt(r.height)},
                         {"allocation_bytes", opt(r.allocationBytes)},
                         {"format_bytes", opt(r.formatBytes)},
                         {"usage", opt(r.usage)}});
  }
  j["resources"] = resources;
  j["shaders"] = run->shaders;
  j["counter_headroom"] = run->counterHeadroom;
  j["ceilings"] = run->ceilings;  // the roofline's device ceilings (docs/measurement.md)
  json passes = json::array();
  for (const auto& p : check(reader(ctx).runPasses(id))) passes.push_back(passJson(p));
  j["passes"] = passes;
  return Response::ok(j);
}

Response listSweeps(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"name", "device", "capture", "since", "until", "limit", "cursor"});
  // The same device, capture and time filters as /api/runs.
  store::RunFilter common = queryFilter(req);
  store::SweepFilter filter;
  filter.name = queryString(req, "name");
  filter.deviceId = common.deviceId;
  filter.deviceName = common.deviceName;
  filter.jobId = common.jobId;
  filter.createdSince = common.createdSince;
  filter.createdUntil = common.createdUntil;
  auto page = check(reader(ctx).listSweeps(filter, queryPage(req)));
  json sweeps = json::array();
  for (const auto& s : page.sweeps) sweeps.push_back(sweepRowJson(s));
  return Response::ok(
      {{"sweeps", sweeps}, {"next_cursor", page.nextCursor.empty() ? json(nullptr) : json(page.nextCursor)}});
}

Response getSweep(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto sweep = check(reader(ctx).getSweep(id));
  if (!sweep) return api::notFound("no sweep " + std::to_string(id));
  json j = sweepRowJson(sweep->row);
  j["result"] = sweep->result;
  return Response::ok(j);
}

Response listSamples(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto& store = reader(ctx);
  if (!check(store.getRun(id))) return api::notFound("no run " + std::to_string(id));
  json samples = json::array();
  for (const auto& s : check(store.listSamples(id))) samples.push_back(sampleRowJson(s));
  return Response::ok({{"samples", samples}});
}

Response getSample(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto sample = check(reader(ctx).getSample(id));
  if (!sample) return api::notFound("no sample " + std::to_string(id));
  json j = sampleRowJson(sample->row);
  // Per-frame times (0008): null where not stored.
  auto frameTimes = [](const std::vector<double>& ms) { return ms.empty() ? json(nullptr) : json(ms); };
  j["frame_ms_frames"] = frameTimes(sample->row.frameMsFrames);
  json passes = json::array();
  for (const auto& p : sample->passes) {
    json pass = passJson(p);
    pass["gpu_ms_frames"] = frameTimes(p.gpuMsFrames);
    passes.push_back(std::move(pass));
  }
  j["passes"] = passes;
  return Response::ok(j);
}

// The sample as a Chrome trace-event JSON trace (service/trace.hpp).
Response getSampleTrace(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto& store = reader(ctx);
  auto sample = check(store.getSample(id));
  if (!sample) return api::notFound("no sample " + std::to_string(id));
  auto run = check(store.getRun(sample->row.runId));
  if (!run) return api::notFound("no run for sample " + std::to_string(id));
  return Response::ok(sampleTrace(run->row, *sample));
}

Response getScreenshot(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto png = check(reader(ctx).getScreenshot(id));
  if (!png) return api::notFound("no screenshot for sample " + std::to_string(id));
  return Response::raw(std::string(png->begin(), png->end()), "image/png");
}

// ?runs=a,b,...: distinct positive run ids, between `least` and `most` of them.
std::vector<int64_t> runIdList(const Request& req, size_t least, size_t most) {
  std::string expected = "must be " + std::to_string(least) + " to " + std::to_string(most) + " run ids, comma-separated";
  const std::string* list = req.queryValue("runs");
  if (!list) invalid("runs", "required: " + std::to_string(least) + " to " + std::to_string(most) + " run ids, comma-separated");
  std::vector<int64_t> ids;
  std::stringstream in(*list);
  std::string item;
  while (std::getline(in, item, ',')) {
    size_t used = 0;
    int64_t n = 0;
    try {
      n = std::stoll(item, &used, 10);
    } catch (const std::exception&) {
      used = 0;
    }
    if (item.empty() || used != item.size() || !std::isdigit(static_cast<unsigned char>(item[0])) || n < 1) {
      invalid("runs", expected);
    }
    for (int64_t seen : ids) {
      if (seen == n) invalid("runs", "run " + item + " is listed twice");
    }
    ids.push_back(n);
    if (ids.size() > most) break;
  }
  if (!list->empty() && list->back() == ',') invalid("runs", expected);
  if (ids.size() < least || ids.size() > most) invalid("runs", expected);
  return ids;
}

Response compare(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"runs", "confidence", "threshold", "across_capture", "strata"});
  std::vector<int64_t> ids = runIdList(req, 2, 4);
  SignificanceOptions options;
  options.compare.confidence = queryDouble(req, "confidence", 0.5, 1, false, true).value_or(0.95);
  options.compare.practicalThreshold = queryDouble(req, "threshold", 0, 10, false, false).value_or(0);
  options.acrossCapture = queryBool(req, "across_capture").value_or(true);
  std::string strata = queryString(req, "strata", 16).value_or("cameras");
  if (strata != "cameras" && strata != "none") invalid("strata", "must be cameras or none");
  options.camerasAsStrata = strata == "cameras";
  auto& store = reader(ctx);
  for (int64_t id : ids) {
    if (!check(store.getRun(id))) return api::notFound("no run " + std::to_string(id));
  }
  json out = comparisonJson(check(store.compareRuns(ids)));
  // Each later run against the first: times tested, counts exact.
  json significance = json::array();
  for (size_t i = 1; i < ids.size(); ++i) {
    significance.push_back(toJson(check(runSignificance(store, ids[0], ids[i], options))));
  }
  out["significance"] = std::move(significance);
  out["confidence"] = options.compare.confidence;
  out["threshold"] = options.compare.practicalThreshold;
  return Response::ok(std::move(out));
}

// Each variant's metric fitted against the pixel count over one capture's
// runs, and where pairs of variants cross (service/crossover.hpp).
Response crossover(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"capture", "metric", "scene", "device"});
  if (!req.queryValue("capture")) invalid("capture", "required: the capture whose runs are fitted");
  std::string metric = queryString(req, "metric", 16).value_or("bytes");
  if (!isCrossoverMetric(metric)) invalid("metric", "must be bytes or frame_ms");
  store::RunFilter filter = queryFilter(req);
  auto& store = reader(ctx);
  if (!check(store.getJob(*filter.jobId))) return api::notFound("no capture " + std::to_string(*filter.jobId));
  return Response::ok(check(crossoverModels(store, filter, metric)));
}

// A heatmap capture's map: one variant's metric per cell, or two variants'
// and their ratio with its significance (service/heatmap.hpp).
Response heatmap(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"capture", "renderer", "versus", "metric", "yaw", "scene", "width", "height", "counting"});
  if (!req.queryValue("capture")) invalid("capture", "required: the heatmap capture");
  HeatmapQuery q;
  q.capture = *queryInt(req, "capture", 1, INT64_MAX);
  auto renderer = queryString(req, "renderer");
  if (!renderer) invalid("renderer", "required: the variant measured (its label, e.g. deferred)");
  q.renderer = *renderer;
  q.versus = queryString(req, "versus");
  q.metric = queryString(req, "metric", 16).value_or("frame_ms");
  if (q.metric != "frame_ms" && q.metric != "bytes") invalid("metric", "must be frame_ms or bytes");
  q.yaw = queryString(req, "yaw", 16).value_or("mean");
  q.scene = queryString(req, "scene");
  q.counting = queryString(req, "counting", 64);
  if (auto w = queryInt(req, "width", 1, kMaxDimension)) q.width = static_cast<int>(*w);
  if (auto h = queryInt(req, "height", 1, kMaxDimension)) q.height = static_cast<int>(*h);
  auto& store = reader(ctx);
  if (!check(store.getJob(q.capture))) return api::notFound("no capture " + std::to_string(q.capture));
  HeatmapAnswer answer = heatmapMap(store, q);
  if (answer.failure) {
    if (answer.failure->status >= 500) check(Result<bool>(makeError(answer.failure->message)));
    throw RequestError(answer.failure->status, answer.failure->status == 404 ? api::code::kNotFound : api::code::kInvalidField,
                       answer.failure->field + ": " + answer.failure->message, answer.failure->field);
  }
  return Response::ok(std::move(answer.body));
}

// The top-down plan of a floor heatmap (PNG).
Response heatmapTopDownPng(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"scene"});
  int64_t id = pathId(req);
  auto scene = queryString(req, "scene");
  auto& store = reader(ctx);
  if (!check(store.getJob(id))) return api::notFound("no capture " + std::to_string(id));
  HeatmapAnswer answer = heatmapTopDown(store, id, scene, ctx.options.sceneFolders);
  if (answer.failure) {
    if (answer.failure->status >= 500) check(Result<bool>(makeError(answer.failure->message)));
    if (answer.failure->status == 404) return api::notFound(answer.failure->message);
    throw RequestError(answer.failure->status, api::code::kInvalidField,
                       answer.failure->field + ": " + answer.failure->message, answer.failure->field);
  }
  return Response::raw(std::string(answer.png.begin(), answer.png.end()), "image/png");
}

Response exportRuns(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"format", "renderer", "variant", "scene", "width", "height", "device", "capture", "since", "until", "runs"});
  std::string format = queryString(req, "format", 8).value_or("json");
  if (format != "csv" && format != "json") invalid("format", "must be csv or json");
  store::RunFilter filter = queryFilter(req);
  if (req.queryValue("runs")) filter.runIds = runIdList(req, 1, 1000);  // the store's limit
  auto rows = check(reader(ctx).exportRuns(filter));
  if (format == "json") {
    json out = json::array();
    for (const auto& r : rows) {
      out.push_back({{"run", r.runId},
                     {"renderer", r.renderer},
                     {"scene", r.scene},
                     {"width", r.width},
                     {"height", r.height},
                     {"device", r.device},
                     {"pass", r.pass},
                     {"resource", r.resource},
                     {"access", r.access},
                     {"count", r.count},
                     {"bytes", r.bytes},
                     {"footprint_bytes", opt(r.footprintBytes)},
                     {"reuse", reuseJson(r.footprintRequestedBytes, r.footprintBytes)}});
    }
    return Response::ok({{"rows", out}});
  }
  // bytes: requested. Where any row has a footprint, two more columns follow,
  // footprint_bytes and reuse (empty where not measured); an export without
  // footprint keeps the columns it always had.
  bool footprint = std::any_of(rows.begin(), rows.end(), [](const store::ExportRow& r) { return r.footprintBytes.has_value(); });
  std::string csv = std::string("run,renderer,scene,width,height,device,pass,resource,access,count,bytes") +
                    (footprint ? ",footprint_bytes,reuse" : "") + "\r\n";
  auto num = [](double v) {
    json j = v;  // shortest round-trip text
    return j.dump();
  };
  auto optNum = [](const json& v) { return v.is_null() ? std::string() : v.dump(); };
  for (const auto& r : rows) {
    csv += std::to_string(r.runId) + "," + csvCell(r.renderer) + "," + csvCell(r.scene) + "," +
           std::to_string(r.width) + "," + std::to_string(r.height) + "," + csvCell(r.device) + "," +
           csvCell(r.pass) + "," + csvCell(r.resource) + "," + csvCell(r.access) + "," + num(r.count) + "," +
           num(r.bytes) +
           (footprint ? "," + optNum(opt(r.footprintBytes)) + "," +
                            optNum(reuseJson(r.footprintRequestedBytes, r.footprintBytes))
                      : std::string()) +
           "\r\n";
  }
  Response resp = Response::raw(std::move(csv), "text/csv; charset=utf-8");
  resp.headers.emplace_back("Content-Disposition", "attachment; filename=\"tally-export.csv\"");
  return resp;
}

Response listDevices(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  json devices = json::array();
  for (const auto& d : check(reader(ctx).listDevices())) devices.push_back(deviceJson(d));
  return Response::ok({{"devices", devices}});
}

Response listHosts(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  json hosts = json::array();
  for (const auto& h : check(reader(ctx).listHosts(ctx.options.staleAfterMs))) hosts.push_back(hostJson(h));
  return Response::ok({{"hosts", hosts}, {"stale_after_s", static_cast<double>(ctx.options.staleAfterMs) / 1000.0}});
}

Response listScenes(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  json procedural = json::array({
      {{"name", "atrium"}, {"parameters", json::object()}},
      {{"name", "planes"},
       {"parameters",
        {{"layers", {{"type", "integer"}, {"default", 8}, {"min", 1}, {"max", 1024}}},
         {"order", {{"type", "string"}, {"default", "back-to-front"}, {"values", {"back-to-front", "front-to-back"}}}},
         {"coverage", {{"type", "number"}, {"default", 1.0}, {"min_exclusive", 0.0}, {"max", 1.0}}}}}},
      {{"name", "sky"}, {"parameters", {{"coverage", {{"type", "number"}, {"default", 0.5}, {"min", 0.0}, {"max", 1.0}}}}}},
  });
  constexpr size_t kMaxFiles = 1000;  // per folder: a listing, not a crawl
  json folders = json::array();
  for (const auto& folder : ctx.options.sceneFolders) {
    std::error_code ec;
    fs::path root = fs::canonical(folder, ec);
    json files = json::array();
    if (!ec) {
      fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec), end;
      for (; !ec && it != end && files.size() < kMaxFiles; it.increment(ec)) {
        if (it.depth() > 8) {
          it.disable_recursion_pending();
          continue;
        }
        auto ext = it->path().extension().string();
        if (ext != ".gltf" && ext != ".glb") continue;
        // Only files inside the folder, listed by their own name: a link is
        // listed when its target is a file inside too (resolveGltf accepts
        // it), and never by where it points.
        std::error_code fileError;
        fs::path real = fs::canonical(it->path(), fileError);
        if (fileError || !under(real, root) || !fs::is_regular_file(real, fileError)) continue;
        files.push_back(it->path().lexically_relative(root).string());
      }
    }
    folders.push_back({{"folder", folder.string()}, {"files", files}});
  }
  return Response::ok({{"procedural", procedural}, {"gltf", folders}});
}

}  // namespace detail

using namespace detail;

std::string csvCell(const std::string& value) {
  std::string v = value;
  // A leading = + - @ would run as a formula in a spreadsheet.
  if (!v.empty() && (v[0] == '=' || v[0] == '+' || v[0] == '-' || v[0] == '@')) v = "'" + v;
  if (v.find_first_of(",\"\r\n") == std::string::npos) return v;
  std::string out = "\"";
  for (char c : v) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

void addServiceRoutes(api::Router& router, ServiceContext& ctx) {
  auto route = [&ctx](Response (*fn)(ServiceContext&, const Request&)) {
    return [&ctx, fn](const Request& req) { return wrap(ctx, [&] { return fn(ctx, req); }); };
  };
  router.post("/api/captures", route(postCapture));
  router.get("/api/captures", route(listCaptures));
  router.get("/api/captures/{id}", route(getCapture));
  router.del("/api/captures/{id}", route(cancelCapture));
  router.get("/api/runs", route(listRuns));
  router.get("/api/runs/{id}", route(getRun));
  router.get("/api/runs/{id}/samples", route(listSamples));
  router.get("/api/sweeps", route(listSweeps));
  router.get("/api/sweeps/{id}", route(getSweep));
  router.get("/api/samples/{id}", route(getSample));
  router.get("/api/samples/{id}/screenshot.png", route(getScreenshot));
  router.get("/api/samples/{id}/trace", route(getSampleTrace));
  router.get("/api/compare", route(compare));
  router.get("/api/crossover", route(crossover));
  router.get("/api/heatmap", route(heatmap));
  router.get("/api/heatmap/{id}/topdown.png", route(heatmapTopDownPng));
  router.get("/api/accuracy", route(accuracy));
  router.get("/api/repeats", route(repeats));
  router.get("/api/export", route(exportRuns));
  router.get("/api/devices", route(listDevices));
  router.get("/api/hosts", route(listHosts));
  router.get("/api/scenes", route(listScenes));
  addAlertRoutes(router, ctx);
}

}  // namespace tally::service
