// The wire mapping: the server's JSON as the views the tables print, and its
// error bodies as one line.
#include "api_client.hpp"

#include <cstdio>
#include <functional>
#include <sstream>

namespace tally::client {

namespace {

const json* field(const json& j, const char* name) {
  if (!j.is_object()) return nullptr;
  auto it = j.find(name);
  return it == j.end() || it->is_null() ? nullptr : &*it;
}
std::string str(const json& j, const char* name) {
  const json* v = field(j, name);
  return v ? idString(*v) : "";
}
std::optional<double> num(const json& j, const char* name) {
  const json* v = field(j, name);
  if (v && v->is_number()) return v->get<double>();
  return std::nullopt;
}
std::optional<int64_t> integer(const json& j, const char* name) {
  const json* v = field(j, name);
  if (v && v->is_number()) return static_cast<int64_t>(v->get<double>());
  return std::nullopt;
}
std::vector<json> array(const json& j, const char* name) {
  const json* v = field(j, name);
  if (!v || !v->is_array()) return {};
  return std::vector<json>(v->begin(), v->end());
}
// The run's aggregate, top level or under "summary".
std::optional<double> runNum(const json& run, std::initializer_list<const char*> names) {
  for (const char* n : names) {
    if (auto v = num(run, n)) return v;
    if (const json* s = field(run, "summary"))
      if (auto v = num(*s, n)) return v;
  }
  return std::nullopt;
}

ComparedView compared(const json& v) {
  ComparedView c;
  if (v.is_number()) {
    c.value = v.get<double>();
  } else if (v.is_object()) {
    c.value = num(v, "value");
    c.delta = num(v, "delta");
    c.ratio = num(v, "ratio");
  }
  return c;
}

std::vector<ComparedView> comparedList(const json& j, const char* name) {
  std::vector<ComparedView> out;
  for (const auto& v : array(j, name)) out.push_back(compared(v));
  // Fill deltas and ratios the server left out.
  for (auto& c : out) {
    if (out.empty() || !out[0].value || !c.value) continue;
    if (!c.delta) c.delta = *c.value - *out[0].value;
    if (!c.ratio && *out[0].value != 0) c.ratio = *c.value / *out[0].value;
  }
  return out;
}


}  // namespace

std::string formatHttpError(int status, const std::string& body) {
  json parsed = json::parse(body, nullptr, false);
  const json* error = parsed.is_discarded() ? nullptr : field(parsed, "error");
  if (error && error->is_object()) {
    std::string code = str(*error, "code"), fieldName = str(*error, "field"),
                message = str(*error, "message");
    std::string head = "error (" + std::to_string(status);
    if (!code.empty()) head += " " + code;
    if (!fieldName.empty()) head += ", field " + fieldName;
    return head + "): " + (message.empty() ? "(no message)" : message);
  }
  std::string line = body.substr(0, body.find('\n'));
  if (line.size() > 200) line = line.substr(0, 200) + "...";
  return "error (" + std::to_string(status) +
         "): " + (line.empty() ? "HTTP " + std::to_string(status) : line);
}

// ---- the wire mapping ---------------------------------------------------------

std::string idString(const json& value) {
  if (value.is_string()) return value.get<std::string>();
  if (value.is_number_integer()) return std::to_string(value.get<int64_t>());
  if (value.is_number_unsigned()) return std::to_string(value.get<uint64_t>());
  if (value.is_null()) return "";
  return value.dump();
}

JobView jobView(const json& job) {
  JobView v;
  v.id = str(job, "id");
  v.status = str(job, "status");
  v.error = str(job, "error");
  v.createdAt = str(job, "created_at");
  if (auto a = integer(job, "attempts")) v.attempts = static_cast<int>(*a);
  if (auto a = integer(job, "max_attempts")) v.maxAttempts = static_cast<int>(*a);
  v.host = str(job, "host");
  v.waiting = str(job, "waiting");
  for (const auto& e : array(job, "attempt_errors")) v.attemptErrors.push_back(idString(e));
  if (const json* p = field(job, "progress")) {
    if (p->is_number()) {
      v.fraction = p->get<double>();
    } else if (p->is_object()) {
      v.done = integer(*p, "done");
      v.total = integer(*p, "total");
      v.current = str(*p, "current");
    }
  }
  if (v.done && v.total && *v.total > 0)
    v.fraction = static_cast<double>(*v.done) / static_cast<double>(*v.total);
  for (const auto& r : array(job, "runs")) v.runs.push_back(idString(r));
  for (const auto& r : array(job, "sweeps")) v.sweeps.push_back(idString(r));
  return v;
}

std::vector<json> jobList(const json& page) { return array(page, "captures"); }

RunView runView(const json& run) {
  RunView v;
  v.id = str(run, "id");
  v.capture = str(run, "capture");
  if (v.capture.empty()) v.capture = str(run, "job_id");
  v.renderer = str(run, "renderer");
  v.variant = str(run, "variant");
  if (v.variant.empty()) v.variant = v.renderer;
  if (const json* o = field(run, "options"); o && o->is_object()) v.options = *o;
  v.scene = str(run, "scene");
  if (const json* d = field(run, "device"); d && d->is_object()) {
    v.device = str(*d, "name");
  } else {
    v.device = str(run, "device");
  }
  v.counting = str(run, "counting");
  v.createdAt = str(run, "created_at");
  v.host = str(run, "host");
  if (const json* l = field(run, "labels"); l && l->is_object()) {
    for (const auto& [k, value] : l->items()) {
      v.labels += (v.labels.empty() ? "" : ",") + k + "=" + (value.is_string() ? value.get<std::string>() : value.dump());
    }
  }
  v.tallyVersion = str(run, "tally_version");
  v.tallyCommit = str(run, "tally_commit");
  v.width = integer(run, "width");
  v.height = integer(run, "height");
  v.lights = integer(run, "lights");
  v.renderTargetBytes = integer(run, "render_target_bytes");
  if (auto s = runNum(run, {"samples", "sample_count"})) v.samples = static_cast<int64_t>(*s);
  v.frameMs = runNum(run, {"frame_ms_median", "frame_ms", "mean_frame_ms"});  // the median where the daemon serves it
  v.bytes = runNum(run, {"bytes", "mean_bytes"});
  v.footprintBlockBytes = integer(run, "footprint_block_bytes");
  v.footprintBytes = runNum(run, {"footprint_bytes", "mean_footprint_bytes"});
  v.reuse = runNum(run, {"reuse", "mean_reuse"});
  return v;
}

std::vector<json> runList(const json& page) { return array(page, "runs"); }
std::string nextCursor(const json& page) { return str(page, "next_cursor"); }

HostView hostView(const json& host) {
  HostView v;
  v.name = str(host, "name");
  v.role = str(host, "role");
  if (const json* d = field(host, "device"); d && d->is_object()) {
    v.probed = true;
    v.deviceName = str(*d, "name");
    v.deviceVendor = str(*d, "vendor");
    v.driver = str(*d, "driver");
    v.apiVersion = str(*d, "api_version");
  }
  v.deviceOverride = str(host, "device_override");
  v.tallyVersion = str(host, "tally_version");
  v.tallyCommit = str(host, "tally_commit");
  v.startedAt = str(host, "started_at");
  v.lastHeartbeat = str(host, "last_heartbeat");
  v.secondsSinceHeartbeat = num(host, "seconds_since_heartbeat");
  if (const json* a = field(host, "alive"); a && a->is_boolean()) v.alive = a->get<bool>();
  v.jobsDone = integer(host, "jobs_done");
  v.jobsFailed = integer(host, "jobs_failed");
  v.currentJob = str(host, "current_job");
  return v;
}

std::vector<json> hostList(const json& page) { return array(page, "hosts"); }
std::optional<double> staleAfterSeconds(const json& page) { return num(page, "stale_after_s"); }

SampleView sampleView(const json& sample) {
  SampleView v;
  v.id = str(sample, "id");
  if (const json* c = field(sample, "camera")) {
    if (c->is_object()) {  // the result's camera: {"eye","target","fov_deg","label","index"}
      // Labels run long ("mostly sky: eye at (...) of bounds, ..."): keep the part before ':'.
      std::string index = str(*c, "index"), label = str(*c, "label");
      if (auto colon = label.find(':'); colon != std::string::npos) label = label.substr(0, colon);
      if (label.rfind("eye at", 0) == 0) label.clear();
      v.camera = index.empty() ? label : label.empty() ? index : index + " " + label;
    } else {
      v.camera = idString(*c);
    }
  }
  if (v.camera.empty()) v.camera = str(sample, "camera_index");
  v.skyFraction = num(sample, "sky_fraction");
  v.frameMs = num(sample, "frame_ms");
  v.overhead = num(sample, "overhead_ratio");
  v.bytes = num(sample, "bytes");
  v.bytesRead = num(sample, "bytes_read");
  v.bytesWritten = num(sample, "bytes_written");
  v.footprintBytes = num(sample, "footprint_bytes");
  v.reuse = num(sample, "reuse");
  if (const json* e = field(sample, "image_error"); e && e->is_object()) {
    v.psnr = num(*e, "psnr");
    v.against = str(*e, "against");
    if (const json* i = field(*e, "identical"); i && i->is_boolean()) v.identical = i->get<bool>();
  }
  if (const json* e = field(sample, "variant_error"); e && e->is_object()) {
    v.hasVariantError = true;
    v.variantPsnr = num(*e, "psnr");
    v.variantAgainst = str(*e, "against");
    if (const json* i = field(*e, "identical"); i && i->is_boolean()) v.variantIdentical = i->get<bool>();
  }
  return v;
}

std::vector<json> sampleList(const json& page) {
  if (page.is_array()) return std::vector<json>(page.begin(), page.end());
  return array(page, "samples");
}

std::pair<double, double> sampleReadWrite(const json& sample) {
  double read = 0, written = 0;
  for (const auto& pass : array(sample, "passes")) {
    // "counters" in the store's terms, "resources" in the capture result's.
    auto counters = array(pass, "counters");
    if (counters.empty()) counters = array(pass, "resources");
    for (const auto& c : counters) {
      double bytes = num(c, "bytes").value_or(0);
      (str(c, "access") == "write" ? written : read) += bytes;
    }
  }
  return {read, written};
}

std::vector<LineView> runLines(const json& run) {
  std::vector<LineView> lines;
  for (const auto& pass : array(run, "passes")) {
    auto counters = array(pass, "resources");
    if (counters.empty()) counters = array(pass, "counters");
    for (const auto& c : counters) {
      std::string name = str(c, "name");
      if (name.empty()) name = str(c, "resource");
      lines.push_back({str(pass, "name"), name, str(c, "access"), num(c, "bytes"), num(c, "footprint_bytes"),
                       num(c, "reuse")});
    }
  }
  return lines;
}

SweepView sweepView(const json& sweep) {
  SweepView v;
  v.id = str(sweep, "id");
  v.capture = str(sweep, "job_id");
  v.name = str(sweep, "name");
  if (const json* d = field(sweep, "device"); d && d->is_object()) {
    v.device = str(*d, "name");
  } else {
    v.device = str(sweep, "device");
  }
  v.createdAt = str(sweep, "created_at");
  v.points = integer(sweep, "point_count");
  for (const auto& p : array(sweep, "parameters")) v.parameters.push_back(idString(p));
  v.threshold = sweep.is_object() ? sweep.value("threshold", json()) : json();
  v.failsAt = sweep.is_object() ? sweep.value("fails_at", json()) : json();
  return v;
}

std::vector<json> sweepList(const json& page) { return array(page, "sweeps"); }

json pointValue(const json& point, const std::string& dotted) {
  const json* at = &point;
  size_t start = 0;
  while (true) {
    size_t dot = dotted.find('.', start);
    at = field(*at, dotted.substr(start, dot == std::string::npos ? std::string::npos : dot - start).c_str());
    if (!at) return nullptr;
    if (dot == std::string::npos) return *at;
    start = dot + 1;
  }
}

namespace {

// "0.01", "1000", "1e-05": a value as a short cell (%.6g for numbers).
std::string shortValue(const json& v) {
  if (v.is_number_float()) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v.get<double>());
    return buf;
  }
  return idString(v);
}

void addGroups(std::vector<FailsAtRow>& rows, const std::string& swept, const json& groups) {
  if (!groups.is_array()) {
    // The whole axis holds, or a bare value for one group.
    rows.push_back({swept, "", groups.is_null() ? "" : shortValue(groups)});
    return;
  }
  for (const auto& g : groups) {
    FailsAtRow row{swept, "", ""};
    if (g.is_object()) {
      for (const auto& [key, value] : g.items()) {
        if (key == swept) {
          row.value = value.is_null() ? "" : shortValue(value);
        } else {
          row.group += (row.group.empty() ? "" : " ") + key + "=" + shortValue(value);
        }
      }
    } else {
      row.value = g.is_null() ? "" : shortValue(g);
    }
    rows.push_back(std::move(row));
  }
}

}  // namespace

std::vector<FailsAtRow> failsAtRows(const json& failsAt, const std::vector<std::string>& parameters) {
  std::vector<FailsAtRow> rows;
  if (failsAt.is_object()) {
    for (const auto& [swept, groups] : failsAt.items()) addGroups(rows, swept, groups);
  } else if (failsAt.is_array()) {
    std::string swept;
    for (auto p = parameters.rbegin(); p != parameters.rend() && swept.empty(); ++p) {
      bool all = !failsAt.empty();
      for (const auto& g : failsAt) {
        const json* v = g.is_object() && g.contains(*p) ? &g[*p] : nullptr;
        all = all && v && (v->is_number() || v->is_null());
      }
      if (all) swept = *p;
    }
    addGroups(rows, swept, failsAt);
  }
  return rows;
}

CompareView compareView(const json& comparison) {
  CompareView v;
  for (const auto& run : array(comparison, "runs")) v.runs.push_back(runView(run));
  auto add = [&](std::string pass, std::string resource, std::string metric,
                 std::vector<ComparedView> values) {
    if (!values.empty())
      v.rows.push_back({std::move(pass), std::move(resource), std::move(metric), std::move(values), {}});
  };
  // Footprint rows only where a compared run has a footprint anywhere; then
  // the bytes rows say which bytes they are: "requested" beside "footprint".
  bool footprint = false;
  for (const auto& c : comparedList(comparison, "total_footprint_bytes")) footprint = footprint || c.value;
  const std::string requested = footprint ? "requested" : "bytes";
  auto addFootprint = [&](const std::string& pass, const std::string& resource, const json& at) {
    if (!footprint) return;
    add(pass, resource, "footprint", comparedList(at, "footprint_bytes"));
    add(pass, resource, "reuse", comparedList(at, "reuse"));
  };
  // The runs' median frame time where the daemon serves it (frame_ms is the mean of camera medians).
  const char* frameMs = comparison.contains("frame_ms_median") ? "frame_ms_median" : "frame_ms";
  add("(frame)", "", "ms", comparedList(comparison, frameMs));
  add("(frame)", "(all)", requested, comparedList(comparison, "total_bytes"));
  if (footprint) {
    add("(frame)", "(all)", "footprint", comparedList(comparison, "total_footprint_bytes"));
    add("(frame)", "(all)", "reuse", comparedList(comparison, "reuse"));
  }
  for (const auto& p : array(comparison, "passes")) {
    std::string name = str(p, "pass");
    if (name.empty()) name = str(p, "name");
    add(name, "", "ms", comparedList(p, "gpu_ms"));
    add(name, "(all)", requested, comparedList(p, "bytes"));
    addFootprint(name, "(all)", p);
    add(name, "", "invocations", comparedList(p, "fragment_invocations"));
  }
  for (const auto& r : array(comparison, "resources")) {
    std::string name = str(r, "resource");
    if (name.empty()) name = str(r, "name");
    std::string access = str(r, "access");
    std::string label = access.empty() ? name : name + " (" + access + ")";
    const size_t first = v.rows.size();
    add("(all passes)", label, requested, comparedList(r, "bytes"));
    addFootprint("(all passes)", label, r);
    for (size_t i = first; i < v.rows.size(); ++i) v.rows[i].access = access;
  }
  return v;
}

}  // namespace tally::client
