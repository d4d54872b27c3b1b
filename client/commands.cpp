#include "commands.hpp"

#include <unistd.h>

#include <sys/stat.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <sstream>
#include <thread>

#include "tables.hpp"

namespace tally::client {

namespace {

using Align = Table::Align;

// Polls in a row that may fail to connect before `tally capture` gives up
// (30 at the default 1 s interval: long enough for tallyd to restart).
constexpr int kMaxUnreachablePolls = 30;

int fail(Io& io, const std::string& message) {
  io.err << "tally: " << message << '\n';
  return 1;
}

void printJson(Io& io, const json& j) { io.out << j.dump(2) << '\n'; }

// A listing (`tally runs`, `tally sweeps`): the response as JSON, or a table
// of one row per item and a hint on stderr when a page was cut short.
int printListing(Io& io, const Result<json>& res, bool all, const std::string& noun, std::vector<Table::Column> columns,
                 const std::function<void(const json& page, Table& table)>& addRows) {
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  Table t(std::move(columns));
  addRows(*res, t);
  t.print(io.out);
  if (!all && !nextCursor(*res).empty()) io.err << "more " << noun << ": add --all, or --limit N\n";
  return 0;
}

std::string size(const RunView& r) {
  if (!r.width || !r.height) return kMissing;
  return std::to_string(*r.width) + "x" + std::to_string(*r.height);
}

std::string orMissing(const std::string& s) { return s.empty() ? kMissing : s; }

std::string progressCell(const JobView& j) {
  if (j.done && j.total) return std::to_string(*j.done) + "/" + std::to_string(*j.total);
  return j.fraction ? percent(j.fraction) : kMissing;
}

// "1/3": attempts so far of the most it gets; "1" from a server that gives no maximum.
std::string attemptsCell(const JobView& j) {
  if (!j.attempts) return kMissing;
  return std::to_string(*j.attempts) + (j.maxAttempts ? "/" + std::to_string(*j.maxAttempts) : "");
}

Result<json> readSpec(const std::string& source) {
  std::string text;
  if (source == "-") {
    std::stringstream s;
    s << std::cin.rdbuf();
    text = s.str();
  } else {
    std::ifstream in(source, std::ios::binary);
    if (!in) return makeError("cannot read spec " + source);
    std::stringstream s;
    s << in.rdbuf();
    text = s.str();
  }
  std::string name = source == "-" ? "stdin" : source;
  try {
    json spec = json::parse(text);
    if (!spec.is_object()) return makeError("spec " + name + ": must be a JSON object");
    return spec;
  } catch (const json::parse_error& e) {
    return makeError("spec " + name + ": not valid JSON: " + e.what());
  }
}

void drawProgress(Io& io, const JobView& j, std::string& last) {
  std::string line = progressLine(j.fraction, j.done, j.total, j.current);
  if (j.status == protocol::kJobQueued)
    line += j.waiting.empty() ? " (queued)" : " (queued: " + j.waiting + ")";
  if (line == last) return;
  last = line;
  if (io.progressTty) {
    io.err << '\r' << line << "\033[K" << std::flush;
  } else {
    io.err << line << '\n' << std::flush;
  }
}

}  // namespace

namespace {
int submitAndFollow(ApiClient& api, const json& spec, const CaptureArgs& args, Io& io);
}  // namespace

Result<json> withLabels(json spec, const std::vector<std::string>& labels) {
  if (labels.empty()) return spec;
  if (!spec.is_object()) return makeError("--label: the spec must be a JSON object");
  if (!spec.contains("labels")) spec["labels"] = json::object();
  if (!spec["labels"].is_object()) return makeError("--label: the spec's \"labels\" is not an object");
  for (const auto& kv : labels) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == kv.size()) {
      return makeError("--label: expected NAME=VALUE, got '" + kv + "'");
    }
    spec["labels"][kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  return spec;
}

int runCapture(ApiClient& api, const CaptureArgs& args, Io& io) {
  auto spec = readSpec(args.spec);
  if (!spec) return fail(io, spec.error());
  auto labelled = withLabels(*spec, args.labels);
  if (!labelled) return fail(io, labelled.error());
  return submitAndFollow(api, *labelled, args, io);
}

Result<json> profileSpec(const ProfileArgs& args) {
  if (args.command.empty() == args.replay.empty()) {
    return makeError("give the application after -- (tally profile -- vkcube --c 100), or --replay FILE, not both");
  }
  if (args.frames < 1 || args.frames > 1000) return makeError("--frames: must be between 1 and 1000");
  if (args.skipFrames < 0) return makeError("--skip-frames: must be 0 or more");
  if (args.frameSubmits < 0) return makeError("--frame-submits: must be 0 or more");
  json env = json::object();
  for (const auto& kv : args.env) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos || eq == 0) return makeError("--env: expected KEY=VALUE, got '" + kv + "'");
    env[kv.substr(0, eq)] = kv.substr(eq + 1);
  }
  const std::string display = args.xvfb ? "xvfb" : "none";
  json spec;
  if (!args.replay.empty()) {
    spec = {{"replay", args.replay}, {"frames", args.frames}, {"skip_frames", args.skipFrames}, {"display", display}};
  } else {
    json app = {{"command", args.command}, {"frames", args.frames}, {"skip_frames", args.skipFrames},
                {"display", display}};
    if (args.frameSubmits > 0) app["frame_submits"] = args.frameSubmits;
    if (!env.empty()) app["env"] = env;
    if (!args.name.empty()) app["name"] = args.name;
    if (args.timeoutS > 0) app["timeout_s"] = args.timeoutS;
    spec = {{"application", app}};
  }
  if (!args.counting.empty()) spec["counting"] = args.counting;
  return spec;
}

int runProfile(ApiClient& api, const ProfileArgs& args, Io& io) {
  auto spec = profileSpec(args);
  if (!spec) return fail(io, spec.error());
  return submitAndFollow(api, *spec, args.capture, io);
}

namespace {
int submitAndFollow(ApiClient& api, const json& spec, const CaptureArgs& args, Io& io) {
  auto created = api.submitCapture(spec, args.idempotencyKey);
  if (!created) return fail(io, created.error());
  JobView job = jobView(*created);
  if (job.id.empty()) return fail(io, "tallyd accepted the capture but sent no id");
  if (args.noWait) {
    if (io.json) {
      printJson(io, *created);
    } else {
      io.out << job.id << '\n';
    }
    return 0;
  }
  io.err << "capture " << job.id << " queued\n";
  std::string last;
  json current = *created;
  int unreachable = 0;  // consecutive polls that could not reach tallyd
  while (!job.finished()) {
    std::this_thread::sleep_for(std::chrono::duration<double>(args.intervalS));
    auto polled = api.getCapture(job.id);
    if (!polled) {
      // The job is stored (202), so a restarting daemon is waited for a while.
      bool transient = polled.error().rfind("cannot reach", 0) == 0;
      if (transient && ++unreachable < kMaxUnreachablePolls) continue;
      if (io.progressTty && !last.empty()) io.err << '\n';
      return fail(io, polled.error());
    }
    unreachable = 0;
    current = *polled;
    job = jobView(current);
    drawProgress(io, job, last);
  }
  if (io.progressTty && !last.empty()) io.err << '\n';
  if (io.json) printJson(io, current);
  if (job.status == protocol::kJobDone) {
    if (!io.json) {
      io.out << "capture " << job.id << " done";
      if (!job.sweeps.empty()) {
        io.out << ": sweep";
        for (const auto& id : job.sweeps) io.out << ' ' << id;
        io.out << " (see `tally sweep " << job.sweeps.front() << "`)";
      } else if (!job.runs.empty()) {
        io.out << ": runs";
        for (const auto& r : job.runs) io.out << ' ' << r;
      } else {
        io.out << " (see `tally runs --capture " << job.id << "`)";
      }
      io.out << '\n';
    }
    return 0;
  }
  if (job.status == protocol::kJobFailed)
    return fail(io, "capture " + job.id + " failed: " + orMissing(job.error));
  return fail(io, "capture " + job.id + " " + job.status);
}
}  // namespace

int runStatus(ApiClient& api, const std::string& id, Io& io) {
  if (!id.empty()) {
    auto res = api.getCapture(id);
    if (!res) return fail(io, res.error());
    if (io.json) {
      printJson(io, *res);
      return 0;
    }
    JobView j = jobView(*res);
    Table t({{"FIELD"}, {"VALUE"}});
    t.addRow({"id", j.id});
    t.addRow({"status", j.status});
    if (!j.host.empty()) t.addRow({"host", j.host});
    if (!j.waiting.empty()) t.addRow({"waiting", j.waiting});
    t.addRow({"progress", progressCell(j)});
    if (!j.current.empty()) t.addRow({"current", j.current});
    if (j.attempts) t.addRow({"attempts", attemptsCell(j)});
    for (const auto& e : j.attemptErrors) t.addRow({"attempt error", e});
    if (!j.createdAt.empty()) t.addRow({"created", j.createdAt});
    if (!j.error.empty()) t.addRow({"error", j.error});
    if (!j.runs.empty()) {
      std::string runs;
      for (const auto& r : j.runs) runs += (runs.empty() ? "" : " ") + r;
      t.addRow({"runs", runs});
    }
    if (!j.sweeps.empty()) {
      std::string sweeps;
      for (const auto& s : j.sweeps) sweeps += (sweeps.empty() ? "" : " ") + s;
      t.addRow({"sweep", sweeps});
    }
    t.print(io.out);
    return 0;
  }
  auto res = api.listCaptures();
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  // A HOST column where any job names one (a fleet; none from a single daemon before hosts).
  std::vector<JobView> jobs;
  bool hosts = false;
  for (const auto& job : jobList(*res)) {
    jobs.push_back(jobView(job));
    hosts = hosts || !jobs.back().host.empty();
  }
  std::vector<Table::Column> columns = {{"ID", Align::Right}, {"STATUS"}};
  if (hosts) columns.push_back({"HOST"});
  columns.insert(columns.end(),
                 {{"PROGRESS", Align::Right}, {"ATTEMPTS", Align::Right}, {"CREATED"}, {"ERROR"}});
  Table t(columns);
  for (const auto& j : jobs) {
    std::vector<std::string> row = {j.id, j.status};
    if (hosts) row.push_back(orMissing(j.host));
    // A queued job that no host can take says why in place of an error.
    std::string error = !j.error.empty() || j.waiting.empty() ? j.error : "waiting: " + j.waiting;
    row.insert(row.end(), {progressCell(j), attemptsCell(j), orMissing(j.createdAt), error});
    t.addRow(row);
  }
  t.print(io.out);
  return 0;
}

int runHosts(ApiClient& api, Io& io) {
  auto res = api.listHosts();
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  Table t({{"NAME"},
           {"ROLE"},
           {"DEVICE"},
           {"DRIVER"},
           {"VERSION"},
           {"HEARTBEAT", Align::Right},
           {"STATE"},
           {"DONE", Align::Right},
           {"FAILED", Align::Right},
           {"JOB", Align::Right}});
  int stale = 0;
  for (const auto& host : hostList(*res)) {
    HostView h = hostView(host);
    std::string device = !h.deviceOverride.empty() ? h.deviceOverride + " (override)"
                         : h.probed                ? orMissing(h.deviceName)
                                                   : "(not probed)";
    std::string version = orMissing(h.tallyVersion);
    if (!h.tallyCommit.empty()) version += " (" + h.tallyCommit + ")";
    std::string state = !h.alive ? kMissing : *h.alive ? "alive" : "stale";
    stale += h.alive && !*h.alive;
    auto count = [](std::optional<int64_t> n) { return n ? std::to_string(*n) : std::string(kMissing); };
    t.addRow({h.name, orMissing(h.role), device, h.probed ? orMissing(h.driver) : kMissing, version,
              ago(h.secondsSinceHeartbeat), state, count(h.jobsDone), count(h.jobsFailed),
              orMissing(h.currentJob)});
  }
  t.print(io.out);
  if (stale) {
    auto after = staleAfterSeconds(*res);
    io.err << stale << (stale == 1 ? " host is" : " hosts are") << " stale: no heartbeat"
           << (after ? " in the last " + fixedOrSci(*after) + " s" : std::string(" lately")) << '\n';
  }
  return 0;
}

int runCancel(ApiClient& api, const std::string& id, Io& io) {
  auto res = api.cancelCapture(id);
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
  } else {
    io.out << "capture " << id << " cancelled\n";
  }
  return 0;
}

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
      t.addRow(row);
    }
  });
}

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
  io.out << "run " << r.id << ": " << r.variant << " on " << r.scene << " at " << size(r) << '\n';
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
  if (run->contains("ceilings") && (*run)["ceilings"].is_object()) {
    const json& c = (*run)["ceilings"];
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
  const json notes = run->contains("notes") && (*run)["notes"].is_object() ? (*run)["notes"] : json::object();
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

  // A variant's error against its reference variant gets a column where any sample has one.
  bool variantErrors = false;
  // Footprint: requested bytes beside the footprint and reuse, where any sample has one.
  bool footprint = r.hasFootprint();
  for (const auto& sample : sampleList(*samples)) {
    SampleView s = sampleView(sample);
    variantErrors = variantErrors || s.hasVariantError;
    footprint = footprint || s.footprintBytes.has_value();
  }
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
  for (const auto& sample : sampleList(*samples)) {
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
    row.push_back(humanBytes(read));
    row.push_back(humanBytes(written));
    if (footprint) {
      row.push_back(humanBytes(s.footprintBytes));
      row.push_back(ratio(s.reuse));
    }
    t.addRow(row);
  }
  t.print(io.out);
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
    for (const auto& l : runLines(*run)) {
      lines.addRow({l.pass, l.resource, l.access, humanBytes(l.bytes), humanBytes(l.footprintBytes), ratio(l.reuse)});
    }
    lines.print(io.out);
  }
  return 0;
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
void printSignificance(const json& comparison, const std::vector<std::string>& names, Io& io) {
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
      t.addRow({run, figure, ratio3(c.value("ratio", 1.0)), intervalText(interval),
                pText(c.value("mann_whitney", json::object()).value("p", 1.0)),
                signedFixed(c.value("cliffs_delta", json::object()).value("delta", 0.0), 2), c.value("verdict", ""), note});
    };
    if (s.value("frame", json()).is_object()) {
      row("(frame)", s["frame"]);
    } else {
      t.addRow({run, "(frame)", kMissing, kMissing, kMissing, kMissing, kMissing, s.value("frame_missing", "")});
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
  t.print(io.out);
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
      io.out << "#" << id << ": " << r.variant << " " << r.scene << " " << size(r) << " on "
             << orMissing(r.device) << '\n';
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
    for (size_t i = 0; i < names.size(); ++i)
      cells.push_back(value(i < row.values.size() ? row.values[i].value : std::nullopt));
    for (size_t i = 1; i < names.size(); ++i) {
      bool has = i < row.values.size();
      cells.push_back(delta(has ? row.values[i].delta : std::nullopt));
      cells.push_back(ratio(has ? row.values[i].ratio : std::nullopt));
    }
    t.addRow(cells);
  }
  t.print(io.out);
  printSignificance(*res, names, io);
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
    if (!fit.is_object()) {
      fits.addRow({str(s, "variant"), str(s, "scene"), kMissing, kMissing, kMissing, kMissing, kMissing, kMissing,
                   "none: " + orMissing(str(s, "error"))});
      continue;
    }
    fits.addRow({str(s, "variant"), str(s, "scene"), std::to_string(fit.value("n", 0)), metricFormat(num(fit, "a")),
                 intervalText(fit["a_ci"], metricFormat), perPixelFormat(num(fit, "b")),
                 intervalText(fit["b_ci"], perPixelFormat), fixed(num(fit, "r2"), 4),
                 fit.value("poor_fit", false) ? "POOR (not linear)" : "ok"});
    for (const auto& p : fit.value("points", json::array())) {
      std::string resolution = p.contains("width") ? std::to_string(p.value("width", 0)) + "x" +
                                                         std::to_string(p.value("height", 0))
                                                   : kMissing;
      residuals.addRow({str(s, "variant"), str(s, "scene"), resolution, pixelsText(num(p, "pixels")),
                        metricFormat(num(p, "value")), metricFormat(num(p, "residual")),
                        p.contains("run") ? "#" + std::to_string(p.value("run", 0)) : kMissing});
    }
  }
  io.out << "FITS\n";
  fits.print(io.out);
  if (residuals.rows() > 0) {
    io.out << "\nRESIDUALS (value - fitted)\n";
    residuals.print(io.out);
  }
  const json crossings = body.value("crossings", json::array());
  io.out << "\nCROSSINGS (pixels* = (a2 - a1) / (b1 - b2), delta-method " << ci << ")\n";
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
    } else {
      lower = str(c, "lower_throughout") + " throughout";
    }
    std::string result = kind == "crosses"         ? "crosses"
                         : kind == "outside_range" ? "no crossing in range"
                         : kind == "parallel"      ? "parallel within error"
                                                   : kind;
    std::string resCi = kMissing;
    if (c.contains("resolution_ci") && c["resolution_ci"].is_array() && c["resolution_ci"].size() == 2) {
      resCi = resolutionText(c["resolution_ci"][0]) + " .. " + resolutionText(c["resolution_ci"][1]);
    }
    t.addRow({str(c, "first"), str(c, "second"), str(c, "scene"), result, pixelsText(num(c, "pixels")),
              intervalText(c.contains("pixels_ci") ? c["pixels_ci"] : json(nullptr), pixelsText),
              resolutionText(c.contains("resolution") ? c["resolution"] : json(nullptr)), resCi, lower});
  }
  t.print(io.out);
  return 0;
}

namespace {

// {"relative": 0.001} -> "relative 0.001"; several keys joined by ", ".
std::string thresholdText(const json& threshold) {
  if (!threshold.is_object()) return threshold.is_null() ? kMissing : threshold.dump();
  std::string text;
  for (const auto& [key, value] : threshold.items()) {
    text += (text.empty() ? "" : ", ") + key + " " + (value.is_number() ? fixedOrSci(value.get<double>()) : value.dump());
  }
  return text.empty() ? kMissing : text;
}

// The list's one-cell summary of fails_at: per swept parameter, how many of
// its groups fail ("distance 1/1, far_over_near 1/2"), or "holds".
std::string failsSummary(const SweepView& s) {
  if (s.failsAt.is_null()) return "holds";
  std::vector<std::pair<std::string, std::pair<int, int>>> counts;  // swept -> failing, groups
  for (const auto& row : failsAtRows(s.failsAt, s.parameters)) {
    auto it = std::find_if(counts.begin(), counts.end(), [&](const auto& c) { return c.first == row.swept; });
    if (it == counts.end()) it = counts.insert(counts.end(), {row.swept, {0, 0}});
    it->second.first += row.value.empty() ? 0 : 1;
    it->second.second += 1;
  }
  std::string text;
  for (const auto& [swept, n] : counts) {
    text += (text.empty() ? "" : ", ") + (swept.empty() ? std::string("groups") : swept) + " " +
            std::to_string(n.first) + "/" + std::to_string(n.second);
  }
  return text;
}

}  // namespace

int runSweeps(ApiClient& api, const SweepsArgs& args, Io& io) {
  auto res = args.all ? api.listAllSweeps(args.filters, args.limit) : api.listSweeps(args.filters, args.limit);
  return printListing(io, res, args.all, "sweeps",
                      {{"ID", Align::Right},
                       {"CAPTURE", Align::Right},
                       {"NAME"},
                       {"CREATED"},
                       {"DEVICE"},
                       {"POINTS", Align::Right},
                       {"THRESHOLD"},
                       {"FAILING GROUPS"}},
                      [](const json& page, Table& t) {
                        for (const auto& sweep : sweepList(page)) {
                          SweepView s = sweepView(sweep);
                          t.addRow({s.id, orMissing(s.capture), s.name, orMissing(s.createdAt),
                                    orMissing(s.device), s.points ? std::to_string(*s.points) : kMissing,
                                    thresholdText(s.threshold), failsSummary(s)});
                        }
                      });
}

int runSweep(ApiClient& api, const std::string& sweepId, Io& io) {
  auto res = api.getSweep(sweepId);
  if (!res) return fail(io, res.error());
  if (io.json) {
    printJson(io, *res);
    return 0;
  }
  SweepView s = sweepView(*res);
  const json result = res->is_object() ? res->value("result", json::object()) : json::object();
  io.out << "sweep " << s.id << ": " << s.name << "   capture: " << orMissing(s.capture) << '\n';
  io.out << "device: " << orMissing(s.device) << "   created: " << orMissing(s.createdAt)
         << "   points: " << (s.points ? std::to_string(*s.points) : kMissing)
         << "   threshold: " << thresholdText(s.threshold) << "\n\n";

  if (s.failsAt.is_null()) {
    io.out << "fails at: nowhere; every point holds over the range\n\n";
  } else {
    Table fails({{"SWEPT"}, {"GROUP"}, {"FAILS AT", Align::Right}});
    for (const auto& row : failsAtRows(s.failsAt, s.parameters)) {
      fails.addRow({orMissing(row.swept), row.group.empty() ? kMissing : row.group,
                    row.value.empty() ? "holds over the range" : row.value});
    }
    fails.print(io.out);
    io.out << '\n';
  }

  // Points: the parameters, then every value the plots draw.
  std::vector<std::string> columns = s.parameters;
  if (result.contains("plots") && result["plots"].is_array()) {
    for (const auto& plot : result["plots"]) {
      for (const char* axis : {"x", "y"}) {
        std::string path = plot.is_object() && plot.contains(axis) ? idString(plot[axis]) : "";
        if (!path.empty() && std::find(columns.begin(), columns.end(), path) == columns.end()) columns.push_back(path);
      }
    }
  }
  std::vector<Table::Column> header;
  for (size_t i = 0; i < columns.size(); ++i) header.push_back({columns[i], Align::Right});
  Table points(header);
  if (result.contains("points") && result["points"].is_array()) {
    for (const auto& point : result["points"]) {
      std::vector<std::string> cells;
      for (const auto& c : columns) {
        json v = pointValue(point, c);
        cells.push_back(v.is_null() ? kMissing : v.is_number() ? fixedOrSci(v.get<double>()) : idString(v));
      }
      points.addRow(cells);
    }
  }
  points.print(io.out);
  return 0;
}

Result<bool> writeFileAtomically(const std::string& path, const std::string& data) {
  namespace fs = std::filesystem;
  fs::path target(path);
  fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::string pattern = (dir / ("." + target.filename().string() + ".tmp.XXXXXX")).string();
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  int fd = ::mkstemp(name.data());
  if (fd < 0) return makeError("cannot create a temporary file beside " + path + ": " + std::strerror(errno));
  size_t written = 0;
  while (written < data.size()) {
    ssize_t n = ::write(fd, data.data() + written, data.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      std::string reason = std::strerror(errno);
      ::close(fd);
      ::unlink(name.data());
      return makeError("cannot write " + path + ": " + reason);
    }
    written += static_cast<size_t>(n);
  }
  ::fchmod(fd, 0644);
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    ::unlink(name.data());
    return makeError("cannot write " + path + ": " + std::strerror(errno));
  }
  if (::rename(name.data(), path.c_str()) != 0) {
    std::string reason = std::strerror(errno);
    ::unlink(name.data());
    return makeError("cannot rename to " + path + ": " + reason);
  }
  return true;
}

int runExport(ApiClient& api, const ExportArgs& args, Io& io) {
  auto body = args.trace ? api.sampleTrace(*args.trace) : api.exportRuns(args.format, args.filters);
  if (!body) return fail(io, body.error());
  if (args.output.empty() || args.output == "-") {
    io.out << *body << std::flush;
    return 0;
  }
  auto written = writeFileAtomically(args.output, *body);
  if (!written) return fail(io, written.error());
  io.err << "wrote " << args.output << " (" << humanBytes(static_cast<double>(body->size())) << ")\n";
  return 0;
}

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
      t.addRow({idString(a.value("id", json())), a.value("status", ""), idString(a.value("baseline", json())),
                idString(a.value("run", json())), metric, a.value("verdict", ""), numberCell(a, "ratio", 3), interval,
                numberCell(a, "p_value", 4), counts ? humanBytes(a.value("value_a", json()).is_number() ? std::optional<double>(a["value_a"].get<double>()) : std::nullopt) : numberCell(a, "value_a", 3),
                counts ? humanBytes(a.value("value_b", json()).is_number() ? std::optional<double>(a["value_b"].get<double>()) : std::nullopt) : numberCell(a, "value_b", 3),
                a.value("created_at", "")});
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
