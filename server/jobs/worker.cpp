#include "jobs/worker.hpp"

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <random>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <system_error>

#include "common/child_process.hpp"

namespace tally::jobs {
namespace fs = std::filesystem;

namespace {
// ingest(): the job is no longer this worker's to store (lost lease, or stopping).
const std::string kLost = "\x01lost";
}  // namespace

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

namespace {

// This machine, for telling our own dead instances from another machine's live ones.
std::string machineId() {
  std::ifstream in("/etc/machine-id");
  std::string id;
  if (in >> id && !id.empty()) return id;
  char name[256] = {};
  gethostname(name, sizeof name - 1);
  return name;
}

}  // namespace

std::string Worker::newInstance() {
  std::random_device random;
  char text[32];
  std::snprintf(text, sizeof text, "%08x", random());
  return machineId() + ":" + std::to_string(getpid()) + ":" + text;
}

bool Worker::instanceIsGone(const std::string& instance) {
  // MACHINE:PID:RANDOM; gone when on this machine and the pid is not running.
  size_t first = instance.find(':');
  size_t second = instance.find(':', first == std::string::npos ? 0 : first + 1);
  if (first == std::string::npos || second == std::string::npos) return false;
  if (instance.substr(0, first) != machineId()) return false;
  long pid = std::strtol(instance.c_str() + first + 1, nullptr, 10);
  if (pid <= 0) return false;
  return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH;
}

Worker::Worker(store::Store& writer, WorkerOptions options) : store_(writer), options_(std::move(options)) {
  if (options_.host.name.empty()) {
    char name[256] = {};
    gethostname(name, sizeof name - 1);
    options_.host.name = name;
  }
  if (options_.host.instance.empty()) options_.host.instance = newInstance();
  if (options_.host.role.empty()) options_.host.role = "all";
}

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
  if (options_.host.name.empty()) return makeError("worker: no host name");
  auto registered = store_.hosts().join(options_.host, options_.staleAfter.count(), instanceIsGone);
  if (!registered) return makeError(registered.error());
  auto recovery = store_.jobs().requeueInterrupted(options_.maxAttempts, options_.host.name);
  if (!recovery) return recovery;
  for (int64_t id : recovery->requeued) log(log::Level::kWarning, id, "interrupted, queued again");
  for (int64_t id : recovery->failed) log(log::Level::kError, id, "interrupted too often, failed");
  return recovery;
}

void Worker::start() {
  stopping_ = false;
  thread_ = std::thread([this] { loop(); });
  if (options_.openHeartbeatStore) heartbeat_ = std::thread([this] { heartbeatLoop(); });
}

void Worker::stop() {
  stopping_ = true;
  wake();
  if (thread_.joinable()) thread_.join();
  if (heartbeat_.joinable()) heartbeat_.join();
}

// Every third of the lease: the host's heartbeat, the current job's lease,
// and the expired leases of hosts that stopped renewing theirs. A failure
// (the database unreachable) is logged and tried again at the next beat;
// the capture in progress goes on.
void Worker::heartbeatLoop() {
  std::unique_ptr<store::Store> store;
  const auto period = std::max(options_.lease / 3, std::chrono::milliseconds(100));
  std::string lastError;
  auto report = [&](const std::string& error) {
    if (error == lastError) return;
    lastError = error;
    if (!error.empty()) log(log::Level::kWarning, std::nullopt, "heartbeat: " + error);
  };
  while (!stopping_) {
    if (!store) {
      auto opened = options_.openHeartbeatStore();
      if (opened) {
        store = std::move(*opened);
      } else {
        report(opened.error());
      }
    }
    if (store) {
      int64_t job = currentJob_.load();
      auto beat = store->hosts().heartbeat(options_.host.name, options_.host.instance,
                                           job ? std::optional<int64_t>(job) : std::nullopt);
      if (!beat) {
        report(beat.error());
      } else {
        if (!*beat) report("host name '" + options_.host.name + "' was taken over by another daemon");
        if (job) {
          store::Lease lease{job, currentAttempt_.load(), options_.host.name};
          auto renewed = store->jobs().renewLease(lease, options_.lease.count());
          if (renewed && !*renewed && currentJob_.load() == job) leaseLost_ = true;
        }
        auto reaped = store->jobs().requeueExpired();
        if (reaped) {
          for (int64_t id : reaped->requeued) log(log::Level::kWarning, id, "lease expired; queued again");
          for (int64_t id : reaped->failed) log(log::Level::kError, id, "lease expired on its last attempt; failed");
          if (*beat) report("");
        } else {
          report(reaped.error());
        }
      }
    }
    std::unique_lock lock(mutex_);
    cv_.wait_for(lock, period, [this] { return stopping_.load(); });
  }
}

void Worker::wake() {
  {
    std::lock_guard lock(mutex_);
    woken_ = true;
    if (waiter_) waiter_->interrupt();
  }
  cv_.notify_all();
}

// The waiter that posted jobs wake this worker through; opened again after a
// failure (the database unreachable), meanwhile the worker polls every
// JobWaiter::kRetryAfterLoss.
store::JobWaiter* Worker::openWaiter(std::string& lastError) {
  {
    std::lock_guard lock(mutex_);
    if (waiter_) return waiter_.get();
  }
  auto opened = store::JobWaiter::open(store_.location());  // without the lock: wake() must not wait on a connect
  if (!opened) {
    if (opened.error() != lastError) log(log::Level::kWarning, std::nullopt, "worker: " + opened.error() + "; polling");
    lastError = opened.error();
    return nullptr;
  }
  lastError.clear();
  std::lock_guard lock(mutex_);
  waiter_ = std::move(*opened);
  if (woken_ || stopping_) waiter_->interrupt();
  return waiter_.get();
}

void Worker::loop() {
  store::Claimer claimer;
  claimer.workerPid = static_cast<int64_t>(getpid());
  claimer.host = options_.host.name;
  claimer.device = options_.host.device;
  claimer.leaseMs = options_.lease.count();
  std::string waiterError;
  auto event = [this](WaitEvent e) {
    if (options_.onWait) options_.onWait(e);
  };
  while (!stopping_) {
    store::JobWaiter* waiter = openWaiter(waiterError);
    // Armed before the claim: a job posted after it wakes the wait below.
    if (waiter) waiter->arm();
    auto claimed = store_.jobs().claim(claimer);
    if (!claimed) {
      log(log::Level::kError, std::nullopt, "worker: cannot claim a job: " + claimed.error());
    } else if (claimed->has_value()) {
      runJob(**claimed);
      continue;
    }
    if (stopping_) break;
    event(WaitEvent::kIdle);
    if (waiter) {
      store::JobWaiter::Wake why = waiter->wait(options_.idlePoll);
      {
        std::lock_guard lock(mutex_);
        woken_ = false;
      }
      event(why == store::JobWaiter::Wake::kPosted    ? WaitEvent::kPosted
            : why == store::JobWaiter::Wake::kTimeout ? WaitEvent::kPolled
                                                      : WaitEvent::kInterrupted);
      continue;
    }
    std::unique_lock lock(mutex_);
    bool woken = cv_.wait_for(lock, std::min(options_.idlePoll, std::chrono::milliseconds(store::JobWaiter::kRetryAfterLoss)),
                              [this] { return woken_ || stopping_.load(); });
    woken_ = false;
    lock.unlock();
    event(woken ? WaitEvent::kInterrupted : WaitEvent::kPolled);
  }
  std::lock_guard lock(mutex_);
  waiter_.reset();
}

namespace {

using Screenshots = std::map<std::string, std::vector<uint8_t>>;

Result<std::vector<uint8_t>> readFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return makeError("cannot read " + path.string());
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// A fresh folder for one attempt of a job. Unique per daemon and attempt: an
// orphaned child of a crashed daemon may still write to an old one.
Result<fs::path> makeJobFolder(const fs::path& tempRoot, const store::Job& job) {
  std::error_code ec;
  fs::path root = tempRoot.empty() ? fs::temp_directory_path(ec) : tempRoot;
  fs::path dir = root / ("tally-job-" + std::to_string(job.id) + "-" + std::to_string(getpid()) + "-" +
                         std::to_string(job.attempts));
  fs::remove_all(dir, ec);
  if (!fs::create_directories(dir, ec) || ec) return makeError("cannot create " + dir.string() + ": " + ec.message());
  return dir;
}

// Removes the job's folder however the job ends.
struct Cleanup {
  fs::path dir;
  ~Cleanup() {
    std::error_code e;
    fs::remove_all(dir, e);
  }
};

Result<bool> writeCaptureSpec(const nlohmann::json& jobSpec, const fs::path& path) {
  // "device" chose the host; the capture itself does not take it.
  nlohmann::json content = jobSpec;
  if (content.is_object()) content.erase("device");
  std::ofstream spec(path);
  spec << content.dump();
  if (!spec) return makeError("cannot write " + path.string());
  return true;
}

// The capture's result JSON, and the name of the device it ran on ("" when it
// names none).
struct CaptureResult {
  nlohmann::json json;
  std::string device;
};

Result<CaptureResult> readResult(const fs::path& path, const std::optional<std::string>& deviceNameOverride) {
  auto text = readFile(path);
  if (!text) return text.failure();
  CaptureResult out;
  nlohmann::json& result = out.json;
  result = nlohmann::json::parse(text->begin(), text->end(), nullptr, false);
  if (result.is_discarded() || !result.is_object()) return makeError("the capture's result is not valid JSON");
  if (result.contains("device") && result["device"].is_object() && result["device"].contains("name") &&
      result["device"]["name"].is_string()) {
    if (deviceNameOverride) {
      // The host reports another name (tests pretending to be other GPUs, sites naming theirs).
      result["device"]["name_reported"] = result["device"]["name"];
      result["device"]["name"] = *deviceNameOverride;
    }
    out.device = result["device"]["name"].get<std::string>();
  }
  return out;
}

// The screenshot files the result's samples name, read from the folder the
// capture wrote them to.
Result<Screenshots> readScreenshots(const nlohmann::json& result, const fs::path& shotDir) {
  Screenshots screenshots;
  try {
    for (const auto& run : result.value("runs", nlohmann::json::array())) {
      for (const auto& sample : run.value("samples", nlohmann::json::array())) {
        if (!sample.contains("screenshot") || !sample["screenshot"].is_string()) continue;
        std::string file = sample["screenshot"].get<std::string>();
        if (file.empty() || file.find('/') != std::string::npos || file == "." || file == "..") {
          return makeError("the capture named a bad screenshot file '" + file + "'");
        }
        auto bytes = readFile(shotDir / file);
        if (!bytes) return bytes.failure();
        screenshots[file] = std::move(*bytes);
      }
    }
  } catch (const nlohmann::json::exception& e) {
    return makeError(std::string("the capture's result is malformed: ") + e.what());
  }
  return screenshots;
}

}  // namespace

void Worker::requeueStopped(const store::Lease& lease, const std::string& why) {
  auto r = store_.jobs().requeue(lease, "stopped: " + why + "; queued again");
  if (!r) {
    log(log::Level::kError, lease.jobId, "cannot queue it again (" + r.error() + "); its lease will expire");
  } else if (*r) {
    log(log::Level::kWarning, lease.jobId, "stopped: " + why + "; queued again");
  }
}

bool Worker::recordFailure(const store::Lease& lease, const std::string& reason) {
  const int64_t job = lease.jobId;
  log(log::Level::kError, job, "failed: " + reason);
  // A store that refuses the write (a full disk, a lost server, a lock)
  // gets it again every ingestRetry until it takes it: the job is failed
  // with its reason as soon as the store accepts writes again, never left
  // running. Stopping meanwhile leaves it running for the next start's
  // recovery (queued again, or failed after max_attempts interruptions).
  for (int attempt = 1;; ++attempt) {
    auto r = store_.jobs().finish(lease, store::JobStatus::Failed, reason);
    if (r) {
      if (!*r)
        log(log::Level::kWarning, job, "no longer held by this host; the failure is not recorded");
      if (attempt > 1) log(log::Level::kInfo, job, "the failure is recorded");
      return true;
    }
    const store::Fault fault = store::lastFault();
    if (fault == store::Fault::kNone || fault == store::Fault::kDamaged) {
      if (options_.onStoreFault) options_.onStoreFault(fault, r.error());
      log(log::Level::kError, job, "cannot record the failure: " + r.error());
      return true;
    }
    if (options_.onStoreFault) options_.onStoreFault(fault, r.error());
    if (attempt == 1 || attempt % 30 == 0) {
      log(log::Level::kWarning, job,
          "cannot record the failure yet (" + store::describe(fault) + "); retrying every " +
              std::to_string(options_.ingestRetry.count()) + " ms: " + r.error());
    }
    std::unique_lock lock(mutex_);
    if (cv_.wait_for(lock, options_.ingestRetry, [this] { return stopping_.load(); })) return false;
  }
}

ChildOptions Worker::captureChild(const store::Job& job, const fs::path& specPath, const fs::path& outPath,
                                  bool& cancelled) {
  ChildOptions child;
  child.argv = {options_.tallydPath, "capture", "--spec", specPath.string(), "--out", outPath.string()};
  if (!options_.device.empty()) {
    child.argv.push_back("--device");
    child.argv.push_back(options_.device);
  }
  child.argv.insert(child.argv.end(), options_.captureArgs.begin(), options_.captureArgs.end());
  child.deadline = options_.deadline;
  const int64_t id = job.id;
  child.onStderrLine = [this, id, &cancelled](const std::string& line) {
    auto p = parseProgressLine(line);
    if (!p) return;
    auto still = store_.jobs().updateProgress(id, p->done, p->total,
                                              p->current.empty() ? std::nullopt : std::optional(p->current));
    if (still && !*still) cancelled = true;
  };
  child.shouldStop = [this, id, &cancelled, lastCheck = std::chrono::steady_clock::now()]() mutable {
    if (leaseLost_) cancelled = true;
    if (stopping_ || cancelled) return true;
    // A cancel between progress lines: look at the job once a second.
    auto now = std::chrono::steady_clock::now();
    if (now - lastCheck >= std::chrono::seconds(1)) {
      lastCheck = now;
      auto current = store_.jobs().get(id);
      if (current && current->has_value() && (*current)->status != store::JobStatus::Running) cancelled = true;
    }
    return cancelled;
  };
  return child;
}

void Worker::runJob(const store::Job& job) {
  const auto started = std::chrono::steady_clock::now();
  const bool isSweep = job.spec.is_object() && job.spec.contains("sweep");
  std::string device;
  auto finished = [&](store::JobStatus status) {
    if (!options_.onFinished) return;
    JobOutcome outcome;
    outcome.id = job.id;
    outcome.status = store::toString(status);
    outcome.kind = isSweep ? "sweep" : "capture";
    outcome.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    outcome.device = device;
    options_.onFinished(outcome);
  };
  const store::Lease lease{job.id, job.attempts, options_.host.name};
  currentAttempt_ = job.attempts;
  leaseLost_ = false;
  currentJob_ = job.id;
  struct Release {
    std::atomic<int64_t>& job;
    ~Release() { job = 0; }
  } release{currentJob_};
  auto fail = [&](const std::string& reason) {
    if (recordFailure(lease, reason)) finished(store::JobStatus::Failed);
  };

  auto dir = makeJobFolder(options_.tempRoot, job);
  if (!dir) return fail(dir.error());
  Cleanup cleanup{*dir};
  fs::path specPath = *dir / "spec.json", outPath = *dir / "result.json";
  if (auto written = writeCaptureSpec(job.spec, specPath); !written) return fail(written.error());

  bool cancelled = false;
  ChildOptions child = captureChild(job, specPath, outPath, cancelled);
  log(log::Level::kInfo, job.id, "running");
  auto ran = runChild(child);
  if (stopping_) return requeueStopped(lease, "the daemon is shutting down (the capture was killed)");
  if (cancelled) {
    auto now = store_.jobs().get(job.id);
    bool wasCancelled = !now || !now->has_value() || (*now)->status == store::JobStatus::Cancelled;
    log(log::Level::kInfo, job.id,
        wasCancelled ? "cancelled" : "stopped: its lease expired and it was queued again");
    finished(store::JobStatus::Cancelled);
    return;
  }
  if (!ran) return fail(ran.error());
  if (!ran->ok()) return fail("capture " + ran->reason());

  auto result = readResult(outPath, options_.deviceNameOverride);
  if (!result) return fail(result.error());
  device = result->device;

  // A spec with "sweep" ran a stability sweep (sweeps::isSweepSpec): its
  // result is one sweeps row, not runs.
  Screenshots screenshots;
  if (isSweep) {
    if (!result->json.contains("sweep") || result->json["sweep"] != job.spec["sweep"]) {
      return fail("the sweep's result names sweep " + result->json.value("sweep", nlohmann::json()).dump() +
                  ", the spec " + job.spec["sweep"].dump());
    }
  } else {
    auto read = readScreenshots(result->json, *dir / (outPath.stem().string() + "-screenshots"));
    if (!read) return fail(read.error());
    screenshots = std::move(*read);
  }

  int64_t stored = 0;
  std::string error = ingest(lease, result->json, screenshots, isSweep, &stored);
  if (error == kLost && stopping_)
    return requeueStopped(lease, "the daemon shut down before the database stored the result");
  if (error == kLost) return;
  if (!error.empty()) return fail((isSweep ? "cannot store the sweep: " : "cannot store the result: ") + error);
  log(log::Level::kInfo, job.id,
      isSweep ? "done, sweep " + std::to_string(stored) : "done, " + std::to_string(stored) + " runs");
  finished(store::JobStatus::Done);
}

std::string Worker::ingest(const store::Lease& lease, const nlohmann::json& result,
                           const std::map<std::string, std::vector<uint8_t>>& screenshots, bool sweep,
                           int64_t* stored) {
  for (int attempt = 1;; ++attempt) {
    auto ingested = sweep ? store_.runs().ingestSweep(lease, result)
                          : store_.runs().ingestCapture(lease, result, screenshots);
    if (ingested) {
      *stored = *ingested;
      return "";
    }
    // Unreachable database: keep the result and try again until it answers
    // (or this daemon stops: the lease then expires and another host reruns
    // it). Any other store fault (a full disk) fails the job with its reason.
    const store::Fault fault = store::lastFault();
    if (fault != store::Fault::kUnreachable) {
      if (fault != store::Fault::kNone && options_.onStoreFault)
        options_.onStoreFault(fault, ingested.error());
      if (ingested.error().find("is no longer held by") != std::string::npos) {
        log(log::Level::kWarning, lease.jobId, "result dropped: " + ingested.error());
        return kLost;
      }
      return ingested.error();
    }
    if (attempt == 1 || attempt % 30 == 0) {
      if (options_.onStoreFault) options_.onStoreFault(fault, ingested.error());
      log(log::Level::kWarning, lease.jobId,
          "cannot reach the database to store the result (" + ingested.error() + "); retrying every " +
              std::to_string(options_.ingestRetry.count()) + " ms");
    }
    std::unique_lock lock(mutex_);
    if (cv_.wait_for(lock, options_.ingestRetry, [this] { return stopping_.load(); })) return kLost;
  }
}

}  // namespace tally::jobs
