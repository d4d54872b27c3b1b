#include "jobs/worker.hpp"

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <system_error>

#include "jobs/child_process.hpp"

namespace tally::jobs {
namespace fs = std::filesystem;

std::optional<ProgressLine> parseProgressLine(const std::string& line) {
  if (line.empty() || line[0] != '[') return std::nullopt;
  size_t slash = line.find('/');
  size_t close = line.find(']');
  if (slash == std::string::npos || close == std::string::npos || slash > close) return std::nullopt;
  try {
    size_t used = 0;
    ProgressLine p;
    std::string a = line.substr(1, slash - 1), b = line.substr(slash + 1, close - slash - 1);
    p.done = std::stoll(a, &used);
    if (used != a.size()) return std::nullopt;
    p.total = std::stoll(b, &used);
    if (used != b.size() || p.done < 0 || p.total < 0) return std::nullopt;
    size_t start = line.find_first_not_of(' ', close + 1);
    if (start != std::string::npos) p.current = line.substr(start);
    return p;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

Worker::Worker(store::Store& writer, WorkerOptions options) : store_(writer), options_(std::move(options)) {}

Worker::~Worker() { stop(); }

void Worker::log(log::Level level, std::optional<int64_t> job, const std::string& message) const {
  log::Event event{level, job, message};
  if (options_.log) {
    options_.log(event);
  } else {
    log::write(event);
  }
}

Result<store::Recovery> Worker::recover() {
  auto recovery = store_.requeueInterrupted(options_.maxAttempts);
  if (!recovery) return recovery;
  for (int64_t id : recovery->requeued) log(log::Level::kWarning, id, "interrupted, queued again");
  for (int64_t id : recovery->failed) log(log::Level::kError, id, "interrupted too often, failed");
  return recovery;
}

void Worker::start() {
  stopping_ = false;
  thread_ = std::thread([this] { loop(); });
}

void Worker::stop() {
  stopping_ = true;
  wake();
  if (thread_.joinable()) thread_.join();
}

void Worker::wake() {
  {
    std::lock_guard lock(mutex_);
    woken_ = true;
  }
  cv_.notify_all();
}

void Worker::loop() {
  while (!stopping_) {
    auto claimed = store_.claimNextJob(static_cast<int64_t>(getpid()));
    if (!claimed) {
      log(log::Level::kError, std::nullopt, "worker: cannot claim a job: " + claimed.error());
    } else if (claimed->has_value()) {
      runJob(**claimed);
      continue;
    }
    std::unique_lock lock(mutex_);
    cv_.wait_for(lock, options_.idlePoll, [this] { return woken_ || stopping_.load(); });
    woken_ = false;
  }
}

namespace {

Result<std::vector<uint8_t>> readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return makeError("cannot read " + path.string());
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

void Worker::runJob(const store::Job& job) {
  const auto started = std::chrono::steady_clock::now();
  const bool isSweep = job.spec.is_object() && job.spec.contains("sweep");
  std::string device;
  auto finished = [&](const char* status) {
    if (!options_.onFinished) return;
    JobOutcome outcome;
    outcome.id = job.id;
    outcome.status = status;
    outcome.kind = isSweep ? "sweep" : "capture";
    outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    outcome.device = device;
    options_.onFinished(outcome);
  };
  auto fail = [&](const std::string& reason) {
    log(log::Level::kError, job.id, "failed: " + reason);
    auto r = store_.finishJob(job.id, store::JobStatus::Failed, reason);
    if (!r) log(log::Level::kError, job.id, "cannot record the failure: " + r.error());
    finished("failed");
  };

  std::error_code ec;
  fs::path root = options_.tempRoot.empty() ? fs::temp_directory_path(ec) : options_.tempRoot;
  // Unique per daemon and attempt: an orphaned child of a crashed daemon may still write to an old one.
  fs::path dir = root / ("tally-job-" + std::to_string(job.id) + "-" + std::to_string(getpid()) + "-" +
                         std::to_string(job.attempts));
  fs::remove_all(dir, ec);
  if (!fs::create_directories(dir, ec) || ec) return fail("cannot create " + dir.string() + ": " + ec.message());
  struct Cleanup {
    fs::path dir;
    ~Cleanup() {
      std::error_code e;
      fs::remove_all(dir, e);
    }
  } cleanup{dir};

  fs::path specPath = dir / "spec.json", outPath = dir / "result.json";
  {
    std::ofstream spec(specPath);
    spec << job.spec.dump();
    if (!spec) return fail("cannot write " + specPath.string());
  }

  ChildOptions child;
  child.argv = {options_.tallydPath, "capture", "--spec", specPath.string(), "--out", outPath.string()};
  if (!options_.device.empty()) {
    child.argv.push_back("--device");
    child.argv.push_back(options_.device);
  }
  child.deadline = options_.deadline;
  bool cancelled = false;
  auto lastCheck = std::chrono::steady_clock::now();
  child.onStderrLine = [&](const std::string& line) {
    auto p = parseProgressLine(line);
    if (!p) return;
    auto still = store_.updateProgress(job.id, p->done, p->total,
                                       p->current.empty() ? std::nullopt : std::optional(p->current));
    if (still && !*still) cancelled = true;
  };
  child.shouldStop = [&] {
    if (stopping_ || cancelled) return true;
    // A cancel between progress lines: look at the job once a second.
    auto now = std::chrono::steady_clock::now();
    if (now - lastCheck >= std::chrono::seconds(1)) {
      lastCheck = now;
      auto current = store_.getJob(job.id);
      if (current && current->has_value() && (*current)->status != store::JobStatus::Running) cancelled = true;
    }
    return cancelled;
  };

  log(log::Level::kInfo, job.id, "running");
  auto ran = runChild(child);
  if (stopping_) return;  // left running: recovery at the next start retries it
  if (cancelled) {
    log(log::Level::kInfo, job.id, "cancelled");
    finished("cancelled");
    return;
  }
  if (!ran) return fail(ran.error());
  if (!ran->ok()) return fail("capture " + ran->reason());

  auto text = readFile(outPath);
  if (!text) return fail(text.error());
  auto result = nlohmann::json::parse(text->begin(), text->end(), nullptr, false);
  if (result.is_discarded() || !result.is_object()) return fail("the capture's result is not valid JSON");
  if (result.contains("device") && result["device"].is_object() && result["device"].contains("name") &&
      result["device"]["name"].is_string()) {
    device = result["device"]["name"].get<std::string>();
  }

  // A spec with "sweep" ran a stability sweep (sweeps::isSweepSpec): its
  // result is one sweeps row, not runs.
  if (isSweep) {
    if (!result.contains("sweep") || result["sweep"] != job.spec["sweep"]) {
      return fail("the sweep's result names sweep " + result.value("sweep", nlohmann::json()).dump() +
                  ", the spec " + job.spec["sweep"].dump());
    }
    auto sweep = store_.ingestSweep(job.id, result);
    if (!sweep) return fail("cannot store the sweep: " + sweep.error());
    auto done = store_.finishJob(job.id, store::JobStatus::Done);
    if (!done) {
      log(log::Level::kError, job.id, "cannot finish: " + done.error());
    } else {
      log(log::Level::kInfo, job.id, "done, sweep " + std::to_string(*sweep));
      finished("done");
    }
    return;
  }

  std::map<std::string, std::vector<uint8_t>> screenshots;
  fs::path shotDir = dir / (outPath.stem().string() + "-screenshots");
  try {
    for (const auto& run : result.value("runs", nlohmann::json::array())) {
      for (const auto& sample : run.value("samples", nlohmann::json::array())) {
        if (!sample.contains("screenshot") || !sample["screenshot"].is_string()) continue;
        std::string file = sample["screenshot"].get<std::string>();
        if (file.empty() || file.find('/') != std::string::npos || file == "." || file == "..") {
          return fail("the capture named a bad screenshot file '" + file + "'");
        }
        auto bytes = readFile(shotDir / file);
        if (!bytes) return fail(bytes.error());
        screenshots[file] = std::move(*bytes);
      }
    }
  } catch (const nlohmann::json::exception& e) {
    return fail(std::string("the capture's result is malformed: ") + e.what());
  }

  auto ingested = store_.ingestCapture(job.id, result, screenshots);
  if (!ingested) return fail("cannot store the result: " + ingested.error());
  auto done = store_.finishJob(job.id, store::JobStatus::Done);
  if (!done) {
    log(log::Level::kError, job.id, "cannot finish: " + done.error());
  } else {
    log(log::Level::kInfo, job.id, "done, " + std::to_string(*ingested) + " runs");
    finished("done");
  }
}

}  // namespace tally::jobs
