// tally_bench_queue: how fast a fleet of workers drains the job queue
// (docs/benchmarks.md). For each worker count W it queues N jobs (a fifth of
// them requiring a device by name), starts W threads, each with its own
// Store connection and registered as a host (bench-w0, bench-w1, ...), and
// lets each loop Store::claimNextJob(Claimer) -> a mock capture that takes
// no time -> Store::ingestCapture(Lease, ...) of a small result (or
// Store::finishJob(Lease, Done) with --no-ingest) until nothing is left that
// its device may take. It times every claim and the whole drain, then checks
// that every job ended done, claimed once. It prints figures and asserts
// none; it exits 1 when a store call fails or the check does not hold.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "report.hpp"
#include "store/store.hpp"

namespace tally::bench {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

// Two device models; workers alternate between them (bench-w0 has the first),
// so every job, with or without a requirement, has a worker that may take it.
constexpr const char* kRequiredDevice = "FakeGPU-A";
constexpr const char* kDeviceNames[] = {"FakeGPU-A 24GB", "FakeGPU-B 16GB"};
constexpr int64_t kLeaseMs = 60000;  // far longer than any job here: no lease expires
constexpr int64_t kStaleAfterMs = 60000;

struct Options {
  std::string store;  // empty: a temporary SQLite file, removed at the end
  std::vector<int> workers = {1, 3, 10};
  int jobs = 2000;
  int devicePercent = 20;  // jobs with a device requirement
  bool ingest = true;
  bool json = false;
};

// ---- the work ------------------------------------------------------------------

json fakeDevice(int worker) {
  return {{"index", 0},
          {"name", kDeviceNames[worker % 2]},
          {"type", "discrete"},
          {"vendorID", "0x10DE"},
          {"deviceID", worker % 2 ? "0x0002" : "0x0001"},
          {"apiVersion", "1.3.280"},
          {"driverInfo", "bench 1.0"},
          {"subgroupSize", 32},
          {"features", {{"int64Atomics", true}, {"fragmentBarycentric", true}}}};
}

json spread(double median) {
  return {{"median", median},    {"q1", median * 0.98}, {"q3", median * 1.02}, {"iqr", median * 0.04},
          {"min", median * 0.9}, {"max", median * 1.1}, {"mean", median},      {"n", 20}};
}

json counter(const char* name, const char* access, double count) {
  return {{"name", name},
          {"format", "R8G8B8A8_UNORM"},
          {"kind", "texture"},
          {"access", access},
          {"count", count},
          {"bytes", count * 4},
          {"count_spread", spread(count)},
          {"source", "counter"}};
}

json pass(const char* name, double gpuMs, double base) {
  return {{"name", name},
          {"gpu_ms", gpuMs},
          {"gpu_ms_spread", spread(gpuMs)},
          {"fragment_invocations", 57600 + base},
          {"resources", {counter("gbuffer.normal", "write", base * 2), counter("depth", "read", base)}}};
}

// A PNG that is only a signature, IHDR and IEND: the store checks the header.
std::vector<uint8_t> standInPng(uint32_t width, uint32_t height) {
  std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13, 'I', 'H', 'D', 'R'};
  for (uint32_t v : {width, height}) {
    for (int shift = 24; shift >= 0; shift -= 8) png.push_back(static_cast<uint8_t>(v >> shift));
  }
  png.insert(png.end(), {8, 6, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82});
  return png;
}

// The mock capture's result: 1 run x 1 sample x 2 passes x 2 counters, with
// a stand-in screenshot, on the worker's device.
struct MockCapture {
  json result;
  std::map<std::string, std::vector<uint8_t>> screenshots;
};

MockCapture mockCapture(const json& spec, const json& device, int64_t jobId) {
  double base = static_cast<double>(jobId % 1000);
  json sample = {
      {"camera", {{"eye", {1.0, 2.0, 3.0}}, {"target", {0.0, 0.0, 0.0}}, {"fov_deg", 60}, {"index", 0}}},
      {"frames", 20},
      {"frame_ms", 1.5},
      {"frame_ms_spread", spread(1.5)},
      {"image_error", {{"against", "forward"}, {"identical", true}, {"max_abs", 0}, {"mean_abs", 0}}},
      {"screenshot", "forward_atrium_320x180_cam0.png"},
      {"passes", {pass("gbuffer", 0.5, base), pass("lighting", 1.0, base + 1)}}};
  json run = {{"renderer", "forward"},
              {"scene", "atrium"},
              {"scene_params", {{"name", "atrium"}}},
              {"width", 320},
              {"height", 180},
              {"counting", "exact"},
              {"lights", 400},
              {"notes", json::object()},
              {"resources",
               {{"render_target_bytes", 320 * 180 * 8},
                {"list",
                 {{{"name", "gbuffer.normal"},
                   {"kind", "attachment"},
                   {"format", "R16G16B16A16_SFLOAT"},
                   {"element_bytes", 8},
                   {"width", 320},
                   {"height", 180},
                   {"allocation_bytes", 320 * 180 * 8},
                   {"format_bytes", 320 * 180 * 8},
                   {"usage", "color_attachment|sampled"}}}}}},
              {"samples", {sample}}};
  MockCapture capture;
  capture.result = {{"device", device}, {"spec", spec}, {"shaders", json::object()}, {"runs", {run}}};
  capture.screenshots["forward_atrium_320x180_cam0.png"] = standInPng(320, 180);
  return capture;
}

// ---- one round: W workers drain N jobs -------------------------------------------

// Nearest rank: the smallest value with at least `p` of all at or below it.
double percentile(const std::vector<double>& sorted, double p) {
  if (sorted.empty()) return 0;
  size_t rank = static_cast<size_t>(std::ceil(p * static_cast<double>(sorted.size())));
  return sorted[std::clamp<size_t>(rank, 1, sorted.size()) - 1];
}

struct Latencies {
  size_t count = 0;
  double p50 = 0, p95 = 0, p99 = 0, max = 0, mean = 0;
};

Latencies summarise(std::vector<double> ms) {
  Latencies out;
  if (ms.empty()) return out;
  std::sort(ms.begin(), ms.end());
  out.count = ms.size();
  out.p50 = percentile(ms, 0.50);
  out.p95 = percentile(ms, 0.95);
  out.p99 = percentile(ms, 0.99);
  out.max = ms.back();
  double sum = 0;
  for (double v : ms) sum += v;
  out.mean = sum / static_cast<double>(ms.size());
  return out;
}

struct WorkerResult {
  std::vector<double> claimMs;  // claims that returned a job
  std::vector<double> workMs;   // ingestCapture(lease) or finishJob(lease)
  std::vector<int64_t> jobIds;  // claimed, in order
  std::vector<double> emptyClaimMs;
  std::string error;  // the first failure; the worker stopped there
};

struct Check {
  std::map<std::string, int64_t> statuses;  // of this round's jobs
  int64_t minAttempts = 0, maxAttempts = 0;
  int64_t claimedTwice = 0;  // job ids more than one worker (or one worker twice) got
  int64_t runs = 0;          // runs stored for this round's jobs (ingest: one per job)
  int64_t hostJobsDone = 0;  // hosts.jobs_done added in this round, over bench-w*
  std::vector<std::string> problems;
  bool ok() const { return problems.empty(); }
};

struct Round {
  int workers = 0;
  int jobs = 0;
  double createSeconds = 0;
  double seconds = 0;  // from the start signal to the last worker's exit
  Latencies claim, work, emptyClaim;
  std::vector<int64_t> perWorker;  // jobs done by each worker
  std::vector<std::string> errors;
  Check check;
};

std::string hostName(int worker) { return "bench-w" + std::to_string(worker); }

// The benchmark's own queries: fixed SQL, values bound.
int64_t scalar(store::Store& s, const std::string& sql, int64_t a = 0, int64_t b = 0) {
  store::Statement q(s.connection(), sql);
  if (sql.find("?1") != std::string::npos) q.bind(1, a);
  if (sql.find("?2") != std::string::npos) q.bind(2, b);
  int64_t out = q.step() && !q.isNull(0) ? q.getInt(0) : 0;
  q.run();
  return out;
}

int64_t hostsJobsDone(store::Store& s, int workers) {
  int64_t total = 0;
  auto hosts = s.hosts().list(kStaleAfterMs);
  if (!hosts) return -1;
  for (const auto& h : *hosts) {
    for (int w = 0; w < workers; ++w) {
      if (h.info.name == hostName(w)) total += h.jobsDone;
    }
  }
  return total;
}

Check checkRound(store::Store& admin, int64_t first, int64_t last, const std::vector<WorkerResult>& results,
                 int64_t hostDoneBefore, int workers, bool ingest) {
  Check c;
  store::Statement q(
      admin.connection(),
      "SELECT status, COUNT(*), MIN(attempts), MAX(attempts) FROM jobs WHERE id BETWEEN ?1 AND ?2 "
      "GROUP BY status ORDER BY status");
  q.bind(1, first).bind(2, last);
  c.minAttempts = INT64_MAX;
  while (q.step()) {
    c.statuses[q.getText(0)] = q.getInt(1);
    c.minAttempts = std::min(c.minAttempts, q.getInt(2));
    c.maxAttempts = std::max(c.maxAttempts, q.getInt(3));
  }
  if (c.minAttempts == INT64_MAX) c.minAttempts = 0;
  const int64_t n = last - first + 1;
  std::set<int64_t> seen;
  for (const auto& r : results) {
    for (int64_t id : r.jobIds) {
      if (!seen.insert(id).second) c.claimedTwice += 1;
    }
  }
  c.runs = scalar(admin, "SELECT COUNT(*) FROM runs WHERE job_id BETWEEN ?1 AND ?2", first, last);
  c.hostJobsDone = hostsJobsDone(admin, workers) - hostDoneBefore;

  int64_t done = c.statuses.count("done") ? c.statuses.at("done") : 0;
  if (done != n) c.problems.push_back(std::to_string(done) + " of " + std::to_string(n) + " jobs done");
  if (c.minAttempts != 1 || c.maxAttempts != 1) {
    c.problems.push_back("attempts " + std::to_string(c.minAttempts) + ".." + std::to_string(c.maxAttempts) +
                         ", expected 1");
  }
  if (c.claimedTwice)
    c.problems.push_back(std::to_string(c.claimedTwice) + " claims of a job already claimed");
  if (static_cast<int64_t>(seen.size()) != n) {
    c.problems.push_back(std::to_string(seen.size()) + " distinct jobs claimed of " + std::to_string(n));
  }
  if (ingest && c.runs != n)
    c.problems.push_back(std::to_string(c.runs) + " runs stored for " + std::to_string(n) + " jobs");
  if (!ingest && c.runs != 0) c.problems.push_back(std::to_string(c.runs) + " runs stored without ingest");
  if (c.hostJobsDone != n) {
    c.problems.push_back("hosts counted " + std::to_string(c.hostJobsDone) + " jobs done of " +
                         std::to_string(n));
  }
  return c;
}

// A start line for the workers: each connects and registers, then waits, so
// that the clock starts with every worker ready.
class StartLine {
 public:
  explicit StartLine(int workers) : waiting_(workers) {}
  void ready() {
    std::unique_lock lock(mutex_);
    if (--waiting_ == 0) changed_.notify_all();
  }
  void waitForAll() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return waiting_ == 0; });
  }
  void go() {
    std::lock_guard lock(mutex_);
    started_ = true;
    changed_.notify_all();
  }
  void waitForGo() {
    std::unique_lock lock(mutex_);
    changed_.wait(lock, [&] { return started_; });
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  int waiting_;
  bool started_ = false;
};

void workerLoop(const std::string& location, int worker, bool ingest, const std::string& instance,
                StartLine& start, WorkerResult& out) {
  auto ms = [](Clock::time_point a, Clock::time_point b) {
    return std::chrono::duration<double, std::milli>(b - a).count();
  };
  std::unique_ptr<store::Store> db;
  store::Claimer claimer;
  [&] {
    auto opened = store::Store::open(location);
    if (!opened) {
      out.error = opened.error();
      return;
    }
    db = std::move(*opened);
    store::HostInfo info;
    info.name = hostName(worker);
    info.instance = instance;
    info.role = "worker";
    info.device = fakeDevice(worker);
    info.tallyVersion = "bench";
    info.tallyCommit = "bench";
    // Stale after 0 ms: the benchmark takes its host names over from an
    // earlier run of itself instead of waiting for their heartbeats to age.
    auto registered = db->hosts().join(info, 0);
    if (!registered) {
      out.error = "registering " + info.name + ": " + registered.error();
      return;
    }
    claimer.workerPid = getpid();
    claimer.host = info.name;
    claimer.device = info.device;
    claimer.leaseMs = kLeaseMs;
  }();
  start.ready();
  start.waitForGo();
  if (!out.error.empty()) return;

  for (;;) {
    auto t0 = Clock::now();
    auto claimed = db->jobs().claim(claimer);
    auto t1 = Clock::now();
    if (!claimed) {
      out.error = "claimNextJob: " + claimed.error();
      return;
    }
    if (!*claimed) {
      out.emptyClaimMs.push_back(ms(t0, t1));
      return;  // nothing left that this worker's device may take
    }
    out.claimMs.push_back(ms(t0, t1));
    const store::Job& job = **claimed;
    out.jobIds.push_back(job.id);
    store::Lease lease{job.id, job.attempts, claimer.host};
    if (ingest) {
      // The mock capture: its result is built before the clock starts again.
      MockCapture capture = mockCapture(job.spec, claimer.device, job.id);
      auto t2 = Clock::now();
      auto stored = db->runs().ingestCapture(lease, capture.result, capture.screenshots);
      out.workMs.push_back(ms(t2, Clock::now()));
      if (!stored) {
        out.error = "ingestCapture(job " + std::to_string(job.id) + "): " + stored.error();
        return;
      }
    } else {
      auto t2 = Clock::now();
      auto finished = db->jobs().finish(lease, store::JobStatus::Done);
      out.workMs.push_back(ms(t2, Clock::now()));
      if (!finished || !*finished) {
        out.error = "finishJob(job " + std::to_string(job.id) +
                    "): " + (finished ? std::string("the lease no longer held") : finished.error());
        return;
      }
    }
  }
}

Result<Round> runRound(const Options& options, const std::string& location, store::Store& admin, int workers,
                       const std::string& instance) {
  Round round;
  round.workers = workers;
  round.jobs = options.jobs;
  auto counts = admin.jobs().counts();
  if (!counts) return makeError(counts.error());
  if ((*counts)["queued"] > 0 || (*counts)["running"] > 0) {
    return makeError("the store already has queued or running jobs; use a fresh database");
  }
  int64_t hostDoneBefore = std::max<int64_t>(0, hostsJobsDone(admin, workers));

  // The queue: every fifth job (by default) requires the first device model.
  auto createStart = Clock::now();
  int64_t first = 0, last = 0;
  int withDevice = 0;
  for (int i = 0; i < options.jobs; ++i) {
    json spec = {{"renderers", {"forward"}},
                 {"scenes", {"atrium"}},
                 {"resolutions", {{320, 180}}},
                 {"bench", {{"workers", workers}, {"job", i}}}};
    // Spread evenly: job i requires the device when the running share falls behind.
    if (static_cast<int64_t>(withDevice) * 100 < static_cast<int64_t>(i + 1) * options.devicePercent) {
      spec["device"] = kRequiredDevice;
      ++withDevice;
    }
    auto created = admin.jobs().create(spec);
    if (!created) return makeError("createJob: " + created.error());
    if (i == 0) first = created->job.id;
    last = created->job.id;
  }
  round.createSeconds = std::chrono::duration<double>(Clock::now() - createStart).count();
  if (last - first + 1 != options.jobs) {
    return makeError("the jobs created are not consecutive ids (another client is creating jobs?)");
  }

  std::vector<WorkerResult> results(static_cast<size_t>(workers));
  StartLine start(workers);
  std::vector<std::thread> threads;
  for (int w = 0; w < workers; ++w) {
    threads.emplace_back(workerLoop, std::cref(location), w, options.ingest, std::cref(instance),
                         std::ref(start), std::ref(results[static_cast<size_t>(w)]));
  }
  start.waitForAll();
  auto began = Clock::now();
  start.go();
  for (auto& t : threads) t.join();
  round.seconds = std::chrono::duration<double>(Clock::now() - began).count();

  std::vector<double> claims, work, empty;
  for (int w = 0; w < workers; ++w) {
    const auto& r = results[static_cast<size_t>(w)];
    claims.insert(claims.end(), r.claimMs.begin(), r.claimMs.end());
    work.insert(work.end(), r.workMs.begin(), r.workMs.end());
    empty.insert(empty.end(), r.emptyClaimMs.begin(), r.emptyClaimMs.end());
    round.perWorker.push_back(static_cast<int64_t>(r.jobIds.size()));
    if (!r.error.empty()) round.errors.push_back(hostName(w) + ": " + r.error);
  }
  round.claim = summarise(std::move(claims));
  round.work = summarise(std::move(work));
  round.emptyClaim = summarise(std::move(empty));
  round.check = checkRound(admin, first, last, results, hostDoneBefore, workers, options.ingest);
  return round;
}

// ---- reporting -------------------------------------------------------------------------

std::string describeEngine(store::Store& s) {
  if (s.engine() == store::Engine::Postgres) {
    store::Statement q(s.connection(), "SHOW server_version");
    std::string version = q.step() ? q.getText(0) : "?";
    q.run();
    store::Statement f(s.connection(), "SHOW fsync");
    std::string fsync = f.step() ? f.getText(0) : "?";
    f.run();
    store::Statement c(s.connection(), "SHOW synchronous_commit");
    std::string sync = c.step() ? c.getText(0) : "?";
    c.run();
    return "PostgreSQL " + version + " (fsync " + fsync + ", synchronous_commit " + sync + ")";
  }
  store::Statement q(s.connection(), "SELECT sqlite_version()");
  std::string version = q.step() ? q.getText(0) : "?";
  q.run();
  return "SQLite " + version + " (WAL, synchronous FULL)";
}

std::string perWorkerRange(const std::vector<int64_t>& perWorker) {
  if (perWorker.empty()) return "-";
  auto [lo, hi] = std::minmax_element(perWorker.begin(), perWorker.end());
  return std::to_string(*lo) + ".." + std::to_string(*hi);
}

void printText(const Options& options, const Machine& machine, const std::string& where,
               const std::string& engine, const std::vector<Round>& rounds) {
  std::printf("Tally queue throughput (Store::claimNextJob(Claimer) -> %s)\n",
              options.ingest ? "Store::ingestCapture(Lease)" : "Store::finishJob(Lease, done)");
  std::printf("machine: %u cores, %s; load average (1, 5, 15 min) %s as timing began, %s as it ended\n",
              machine.cores, machine.cpu.c_str(), machine.loadBefore.c_str(), machine.loadAfter.c_str());
  std::printf("store: %s, %s\n", where.c_str(), engine.c_str());
  std::printf(
      "jobs: %d per round, %d %% requiring {\"device\": \"%s\"}; workers alternate %s and %s (bench-w0 "
      "first)\n",
      options.jobs, options.devicePercent, kRequiredDevice, kDeviceNames[0], kDeviceNames[1]);
  std::printf("per job: %s\n",
              options.ingest
                  ? "ingestCapture of 1 run x 1 sample x 2 passes x 2 counters, a 45-byte screenshot"
                  : "finishJob(done), nothing stored (--no-ingest)");
  std::printf("\n%7s %6s %8s %8s %9s %9s %9s %9s %9s %10s %10s %11s  %s\n", "workers", "jobs", "create s",
              "drain s", "jobs/s", "claim p50", "p95", "p99", "max", "work p50", "work p99", "per host",
              "check");
  for (const auto& r : rounds) {
    std::printf("%7d %6d %8.2f %8.2f %9.1f %9.2f %9.2f %9.2f %9.2f %10.2f %10.2f %11s  %s\n", r.workers,
                r.jobs, r.createSeconds, r.seconds, r.seconds > 0 ? r.jobs / r.seconds : 0.0, r.claim.p50,
                r.claim.p95, r.claim.p99, r.claim.max, r.work.p50, r.work.p99,
                perWorkerRange(r.perWorker).c_str(), r.check.ok() && r.errors.empty() ? "ok" : "FAILED");
  }
  std::printf(
      "(ms; claim: Store::claimNextJob calls that returned a job; work: the %s call; jobs/s: the round's "
      "jobs\n"
      " over the drain, from the start signal to the last worker's exit; per host: jobs each worker did)\n",
      options.ingest ? "ingestCapture(Lease)" : "finishJob(Lease)");
  for (const auto& r : rounds) {
    std::string statuses;
    for (const auto& [status, n] : r.check.statuses) statuses += " " + status + " " + std::to_string(n);
    std::printf(
        "check, %d worker(s):%s; attempts %lld..%lld; runs stored %lld; hosts' jobs_done +%lld;"
        " last empty claims: %zu (max %.2f ms)\n",
        r.workers, statuses.c_str(), static_cast<long long>(r.check.minAttempts),
        static_cast<long long>(r.check.maxAttempts), static_cast<long long>(r.check.runs),
        static_cast<long long>(r.check.hostJobsDone), r.emptyClaim.count, r.emptyClaim.max);
    for (const auto& p : r.check.problems) std::printf("  PROBLEM: %s\n", p.c_str());
    for (const auto& e : r.errors) std::printf("  ERROR: %s\n", e.c_str());
  }
}

json latencyJson(const Latencies& l) {
  return {{"count", l.count}, {"p50_ms", l.p50}, {"p95_ms", l.p95},
          {"p99_ms", l.p99},  {"max_ms", l.max}, {"mean_ms", l.mean}};
}

void printJson(const Options& options, const Machine& machine, const std::string& where,
               const std::string& engine, const std::vector<Round>& rounds) {
  json out;
  out["machine"] = {{"cores", machine.cores},
                    {"cpu", machine.cpu},
                    {"load_before", machine.loadBefore},
                    {"load_after", machine.loadAfter}};
  out["store"] = {{"location", where}, {"engine", engine}};
  out["jobs_per_round"] = options.jobs;
  out["device_percent"] = options.devicePercent;
  out["ingest"] = options.ingest;
  json list = json::array();
  for (const auto& r : rounds) {
    json statuses = json::object();
    for (const auto& [status, n] : r.check.statuses) statuses[status] = n;
    list.push_back({{"workers", r.workers},
                    {"jobs", r.jobs},
                    {"create_seconds", r.createSeconds},
                    {"drain_seconds", r.seconds},
                    {"jobs_per_s", r.seconds > 0 ? r.jobs / r.seconds : 0.0},
                    {"claim", latencyJson(r.claim)},
                    {"work", latencyJson(r.work)},
                    {"empty_claims", latencyJson(r.emptyClaim)},
                    {"jobs_per_worker", r.perWorker},
                    {"check",
                     {{"ok", r.check.ok() && r.errors.empty()},
                      {"statuses", statuses},
                      {"min_attempts", r.check.minAttempts},
                      {"max_attempts", r.check.maxAttempts},
                      {"claimed_twice", r.check.claimedTwice},
                      {"runs", r.check.runs},
                      {"host_jobs_done", r.check.hostJobsDone},
                      {"problems", r.check.problems},
                      {"errors", r.errors}}}});
  }
  out["rounds"] = std::move(list);
  std::printf("%s\n", out.dump(2).c_str());
}

int fail(const std::string& message) {
  std::fprintf(stderr, "tally_bench_queue: %s\n", message.c_str());
  return 1;
}

int run(const Options& options) {
  const bool temporary = options.store.empty();
  const std::string location =
      temporary
          ? (fs::temp_directory_path() / ("tally_bench_queue_" + std::to_string(getpid()) + ".db")).string()
          : options.store;
  auto removeFiles = [&] {
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(location + suffix);
  };
  if (temporary) removeFiles();
  struct Cleanup {
    bool active;
    std::function<void()> remove;
    ~Cleanup() {
      if (active) remove();
    }
  } cleanup{temporary, removeFiles};

  auto admin = store::Store::open(location);
  if (!admin) return fail(admin.error());
  const std::string where = store::isPostgresUrl(location) ? store::redactUrl(location) : location;
  const std::string engine = describeEngine(**admin);
  // One instance for the process: the hosts re-register under it each round.
  const std::string instance = "bench-" + std::to_string(getpid());

  Machine machine = describeMachine();
  std::vector<Round> rounds;
  bool failed = false;
  for (int workers : options.workers) {
    if (!options.json) std::fprintf(stderr, "queue: %d jobs, %d worker(s)\n", options.jobs, workers);
    auto round = runRound(options, location, **admin, workers, instance);
    if (!round) return fail(std::to_string(workers) + " worker(s): " + round.error());
    failed = failed || !round->check.ok() || !round->errors.empty();
    rounds.push_back(std::move(*round));
  }
  machine.loadAfter = loadAverage();
  if (options.json) {
    printJson(options, machine, where, engine, rounds);
  } else {
    printText(options, machine, where, engine, rounds);
  }
  return failed ? 1 : 0;
}

}  // namespace
}  // namespace tally::bench

int main(int argc, char** argv) {
  tally::bench::Options options;
  std::string workers = "1,3,10";
  bool noIngest = false;
  CLI::App app{"tally_bench_queue: claim latency and jobs per second of W workers draining N jobs"};
  app.add_option("--store", options.store,
                 "SQLite file or postgresql:// URL (default: a temporary SQLite file, removed afterwards)");
  app.add_option("--workers", workers, "Worker counts, one round each (comma-separated)")
      ->capture_default_str();
  app.add_option("--jobs", options.jobs, "Jobs per round")
      ->capture_default_str()
      ->check(CLI::Range(1, 10'000'000));
  app.add_option("--device-percent", options.devicePercent, "Share of jobs that require a device")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
  app.add_flag("--no-ingest", noIngest,
               "Finish each job with finishJob(Lease, done) instead of ingesting a result");
  app.add_flag("--json", options.json, "Print the figures as JSON");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  options.ingest = !noIngest;
  options.workers.clear();
  std::stringstream list(workers);
  for (std::string item; std::getline(list, item, ',');) {
    int n = 0;
    try {
      n = std::stoi(item);
    } catch (const std::exception&) {
      n = 0;
    }
    if (n < 1 || n > 150) {
      std::fprintf(stderr, "tally_bench_queue: --workers: '%s' is not a count from 1 to 150\n", item.c_str());
      return 2;
    }
    options.workers.push_back(n);
  }
  if (options.workers.empty()) {
    std::fprintf(stderr, "tally_bench_queue: --workers: give at least one count\n");
    return 2;
  }
  try {
    return tally::bench::run(options);
  } catch (const std::exception& e) {  // errors of the benchmark's own queries
    std::fprintf(stderr, "tally_bench_queue: %s\n", e.what());
    return 1;
  }
}
