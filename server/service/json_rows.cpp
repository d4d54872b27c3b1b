// Stored rows as the routes answer them: jobs, hosts, runs, sweeps, samples,
// passes and comparisons.
#include "service/json_rows.hpp"

#include <functional>
#include <utility>

namespace tally::service::detail {
using nlohmann::json;

// Reuse: requested bytes over the footprint of the same lines (how many
// times each distinct byte was asked for); null without a footprint or at 0.
std::optional<double> reuseOf(std::optional<double> requested, std::optional<double> footprint) {
  if (!footprint || *footprint <= 0) return std::nullopt;
  return requested.value_or(0) / *footprint;
}

json reuseJson(std::optional<double> requested, std::optional<double> footprint) {
  return opt(reuseOf(requested, footprint));
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

namespace {

json jsonOf(const json& v) { return v; }
template <class T>
json jsonOf(const T& v) {
  return json(v);
}
template <class T>
json jsonOf(const std::optional<T>& v) {
  return opt(v);
}

// A run row's fields into a json object (runRowJson)...
struct ObjectFields {
  json& j;
  template <class T>
  void field(const char* key, const T& v) {
    j[key] = jsonOf(v);
  }
  template <class Fill>
  void object(const char* key, bool present, Fill fill) {
    if (!present) {
      j[key] = nullptr;
      return;
    }
    json o = json::object();
    ObjectFields inner{o};
    fill(inner);
    j[key] = std::move(o);
  }
  // An array of objects, one per item, each filled by fill(fields, item).
  template <class Items, class Fill>
  void objects(const char* key, const Items& items, Fill fill) {
    json a = json::array();
    for (const auto& item : items) {
      json o = json::object();
      ObjectFields inner{o};
      fill(inner, item);
      a.push_back(std::move(o));
    }
    j[key] = std::move(a);
  }
};

// ...or as text (writeRunRow): the same bytes as that object's dump().
struct TextFields;
// An object, or an array of objects (one per item), as text: filled by
// fill(fields) or fill(fields, item) through TextFields.
template <class Fill>
void writeObject(JsonText& t, Fill fill);
template <class Items, class Fill>
void writeObjects(JsonText& t, const Items& items, Fill fill);

struct TextFields {
  JsonText& t;
  template <class T>
  void field(const char* key, const T& v) {
    t.key(key);
    t.value(v);
  }
  template <class Fill>
  void object(const char* key, bool present, Fill fill) {
    t.key(key);
    if (present) {
      writeObject(t, fill);
    } else {
      t.null();
    }
  }
  template <class Items, class Fill>
  void objects(const char* key, const Items& items, Fill fill) {
    t.key(key);
    writeObjects(t, items, fill);
  }
};

template <class Fill>
void writeObject(JsonText& t, Fill fill) {
  t.beginObject();
  TextFields inner{t};
  fill(inner);
  t.endObject();
}

template <class Items, class Fill>
void writeObjects(JsonText& t, const Items& items, Fill fill) {
  t.beginArray();
  for (const auto& item : items) writeObject(t, [&](TextFields& inner) { fill(inner, item); });
  t.endArray();
}

// TextFields with more keys than a field list names: each extra is written
// where its key falls among the list's (the keys of an object ascend).
// `extras` ascending; finish() writes those after the list's last key.
struct MergedTextFields {
  using Extra = std::pair<const char*, std::function<void(JsonText&)>>;
  JsonText& t;
  std::vector<Extra> extras;
  size_t next = 0;
  void before(std::string_view key) {
    for (; next < extras.size() && std::string_view(extras[next].first) < key; ++next) {
      t.key(extras[next].first);
      extras[next].second(t);
    }
  }
  void finish() {
    for (; next < extras.size(); ++next) {
      t.key(extras[next].first);
      extras[next].second(t);
    }
  }
  template <class T>
  void field(const char* key, const T& v) {
    before(key);
    TextFields{t}.field(key, v);
  }
  template <class Fill>
  void object(const char* key, bool present, Fill fill) {
    before(key);
    TextFields{t}.object(key, present, fill);
  }
};

// The one list of a run row's keys, in the order nlohmann writes them
// (ascending; JsonText refuses any other). With a frame time, its median
// and source (frame_ms_median, frame_ms_median_source).
template <class Fields>
void runRowFields(const store::RunRow& r, const store::RunFrameTime* frame, Fields& f) {
  f.field("capture", r.jobId);
  f.field("counting", r.counting);
  f.field("created_at", r.createdAt);
  f.field("device", r.deviceName);
  f.field("device_id", r.deviceId);
  f.field("footprint_block_bytes", r.footprintBlockBytes);
  if (frame) {
    f.field("frame_ms_median", frame->median);
    f.field("frame_ms_median_source", frame->source);
  }
  f.field("height", r.height);
  f.field("host", r.host);
  f.field("id", r.id);
  f.object("image_error", r.imageCompared != 0, [&](auto& e) {
    e.field("identical", r.imageIdentical);
    e.field("mean_psnr", r.meanPsnr);
    e.field("min_psnr", r.minPsnr);
    e.field("samples", r.imageCompared);
  });
  f.field("labels", r.labels);
  f.field("lights", r.lights);
  f.field("mean_bytes", r.meanBytes);
  f.field("mean_footprint_bytes", r.meanFootprintBytes);
  f.field("mean_frame_ms", r.meanFrameMs);
  f.field("mean_frame_ms_instrumented", r.meanFrameMsInstrumented);
  f.field("mean_overhead_ratio", r.meanOverheadRatio);
  f.field("mean_reuse", reuseOf(r.meanFootprintRequestedBytes, r.meanFootprintBytes));
  f.field("notes", r.notes);
  f.field("options", r.options);
  f.field("render_target_bytes", r.renderTargetBytes);
  f.field("renderer", r.renderer);
  f.field("sample_count", r.sampleCount);
  f.field("scene", r.scene);
  f.field("scene_params", r.sceneParams);
  f.field("tally_commit", r.tallyCommit);
  f.field("tally_version", r.tallyVersion);
  f.field("variant", r.variant);
  f.field("width", r.width);
}

// A pass's keys (passJson, runDetailText), in ascending order; its bytes and
// footprint summed over its resources' lines.
template <class Fields>
void passFields(const store::Pass& p, Fields& f) {
  double bytes = 0;
  std::optional<double> footprint, footprintRequested;  // over the lines that have a footprint
  for (const auto& c : p.counters) {
    bytes += c.bytes;
    if (c.footprintBytes) {
      footprint = footprint.value_or(0) + *c.footprintBytes;
      footprintRequested = footprintRequested.value_or(0) + c.bytes;
    }
  }
  f.field("bytes", bytes);
  f.field("compute_invocations", p.computeInvocations);
  f.field("compute_invocations_statistic", p.computeInvocationsStatistic);
  f.field("footprint_bytes", footprint);
  f.field("fragment_invocations", p.fragmentInvocations);
  f.field("fragment_invocations_statistic", p.fragmentInvocationsStatistic);
  f.field("gpu_ms", p.gpuMs);
  f.field("gpu_ms_instrumented", p.gpuMsInstrumented);
  f.field("gpu_ms_spread", p.gpuMsSpread);
  f.field("name", p.name);
  f.field("overhead_ratio", p.overheadRatio);
  f.objects("resources", p.counters, [](auto& r, const store::Counter& c) {
    r.field("access", c.access);
    r.field("bytes", c.bytes);
    r.field("count", c.count);
    r.field("count_spread", c.countSpread);
    r.field("footprint_bytes", c.footprintBytes);
    r.field("format", c.format);
    r.field("kind", c.kind);
    r.field("name", c.resource);
    r.field("reuse", reuseOf(c.bytes, c.footprintBytes));
    r.field("source", c.source);
  });
  f.field("reuse", reuseOf(footprintRequested, footprint));
}

template <class Fields>
void deviceFields(const store::Device& d, Fields& f) {
  f.field("api_version", d.apiVersion);
  f.field("driver", d.driver);
  f.field("features", d.features);
  f.field("id", d.id);
  f.field("info", d.info);
  f.field("name", d.name);
  f.field("vendor", d.vendor);
}

template <class Fields>
void resourceFields(const store::RunResource& r, Fields& f) {
  f.field("allocation_bytes", r.allocationBytes);
  f.field("element_bytes", r.elementBytes);
  f.field("format", r.format);
  f.field("format_bytes", r.formatBytes);
  f.field("height", r.height);
  f.field("kind", r.kind);
  f.field("name", r.name);
  f.field("usage", r.usage);
  f.field("width", r.width);
}

}  // namespace

json runRowJson(const store::RunRow& r, const store::RunFrameTime* frame) {
  json j = json::object();
  ObjectFields fields{j};
  runRowFields(r, frame, fields);
  return j;
}

void writeRunRow(JsonText& out, const store::RunRow& r, const store::RunFrameTime* frame) {
  out.beginObject();
  TextFields fields{out};
  runRowFields(r, frame, fields);
  out.endObject();
}

std::string runPageText(const store::RunPage& page, const std::map<int64_t, store::RunFrameTime>& frameTimes) {
  std::string body;
  body.reserve(1024 * (page.runs.size() + 1));  // about 850 bytes a run
  JsonText out(body);
  out.beginObject();
  out.key("next_cursor");
  if (page.nextCursor.empty()) {
    out.null();
  } else {
    out.value(page.nextCursor);
  }
  out.key("runs");
  out.beginArray();
  const store::RunFrameTime none;
  for (const auto& r : page.runs) {
    auto it = frameTimes.find(r.id);
    writeRunRow(out, r, it == frameTimes.end() ? &none : &it->second);
  }
  out.endArray();
  out.endObject();
  return body;
}

json deviceJson(const store::Device& d) {
  json j = json::object();
  ObjectFields fields{j};
  deviceFields(d, fields);
  return j;
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
  json j = json::object();
  ObjectFields fields{j};
  passFields(p, fields);
  return j;
}

std::string runDetailText(const store::RunDetail& d, const store::RunFrameTime* frame) {
  std::string body;
  body.reserve(16384);
  JsonText out(body);
  out.beginObject();
  MergedTextFields fields{out, {}};
  fields.extras = {
      {"ceilings", [&](JsonText& t) { t.value(d.run.ceilings); }},
      {"counter_headroom", [&](JsonText& t) { t.value(d.run.counterHeadroom); }},
      {"device_info", [&](JsonText& t) { writeObject(t, [&](auto& f) { deviceFields(d.run.device, f); }); }},
      {"passes",
       [&](JsonText& t) { writeObjects(t, d.passes, [](auto& f, const store::Pass& p) { passFields(p, f); }); }},
      {"resources",
       [&](JsonText& t) {
         writeObjects(t, d.run.resources, [](auto& f, const store::RunResource& r) { resourceFields(r, f); });
       }},
      {"shaders", [&](JsonText& t) { t.value(d.run.shaders); }},
  };
  runRowFields(d.run.row, frame, fields);
  fields.finish();
  out.endObject();
  return body;
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

}  // namespace tally::service::detail
