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

#include "command_support.hpp"
#include "tables.hpp"

namespace tally::client {

namespace {

using Align = Table::Align;

// Polls in a row that may fail to connect before `tally capture` gives up
// (30 at the default 1 s interval: long enough for tallyd to restart).
constexpr int kMaxUnreachablePolls = 30;

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

}  // namespace tally::client
