// Worker: the one thread that runs capture jobs. It owns the writer Store's
// job transitions: claims the oldest queued job its device can run (as a host
// of the fleet: docs/fleet.md), runs `tallyd capture` on it
// in a child process (so a crash, hang, lost device or OOM ends only that
// job), reports progress, ingests the result (its runs, or for a sweep spec
// the sweep) and finishes the job.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <map>
#include <memory>
#include <thread>
#include <vector>

#include "common/log.hpp"
#include "common/result.hpp"
#include "store/job_waiter.hpp"
#include "store/store.hpp"

namespace tally::jobs {

struct ChildOptions;  // common/child_process.hpp

// An idle worker's waits: it found nothing to claim and began waiting
// (kIdle), then was woken by a posted job, by its fallback poll's timeout,
// or by wake() or stop().
enum class WaitEvent { kIdle, kPosted, kPolled, kInterrupted };

struct WorkerOptions {
  std::string tallydPath;  // the executable run as `tallyd capture ...`
  std::string device;      // passed as --device when not empty
  // More arguments of every `tallyd capture` (the daemon's application
  // policy: --confine-applications, --application-root, ...).
  std::vector<std::string> captureArgs;
  std::chrono::milliseconds deadline{std::chrono::minutes(30)};  // per job
  int maxAttempts = 3;              // a job interrupted this often fails on restart
  std::filesystem::path tempRoot;   // empty: std::filesystem::temp_directory_path()
  // The fallback poll of an idle worker. Posted jobs wake it at once
  // (store/job_waiter.hpp: LISTEN/NOTIFY on PostgreSQL, in-process on
  // SQLite); the poll finds only what no announcement reached it for: a job
  // posted by another process on the same SQLite file, or one posted while
  // its PostgreSQL listener was reconnecting (then it polls every second).
  std::chrono::milliseconds idlePoll{std::chrono::seconds(30)};
  // How each idle wait began and ended (tests and benchmarks); may be empty.
  std::function<void(WaitEvent)> onWait;
  std::function<void(const log::Event&)> log;  // default: log::write (stderr, one line per event)
  // Called as each job leaves the worker (not when stop() leaves it running).
  std::function<void(const struct JobOutcome&)> onFinished;

  // The fleet. Every claim is held under a lease, renewed by a heartbeat
  // thread on its own connection (openHeartbeatStore), which also reaps
  // other hosts' expired leases. host.device is what claims are matched
  // against (null: only jobs without a device requirement).
  store::HostInfo host;
  std::optional<std::string> deviceNameOverride;  // results record this device name
  std::chrono::milliseconds lease{std::chrono::seconds(30)};
  std::chrono::milliseconds staleAfter{std::chrono::seconds(30)};
  std::function<Result<std::unique_ptr<store::Store>>()> openHeartbeatStore;
  // How long to wait between ingest attempts while the database is
  // unreachable, and between attempts to record a job's failure while the
  // store refuses writes (a full disk).
  std::chrono::milliseconds ingestRetry{std::chrono::seconds(2)};
  // A store fault met while storing or finishing a job (the daemon's health
  // hears of it); may be empty.
  std::function<void(store::Fault, const std::string&)> onStoreFault;
};

// How a job ended, for the daemon's metrics.
struct JobOutcome {
  int64_t id = 0;
  std::string status;   // "done", "failed" or "cancelled"
  std::string kind;     // "capture" or "sweep"
  double seconds = 0;   // from claiming the job to its end
  std::string device;   // the device the capture ran on (its result's device.name); "" when unknown
};

// "[3/12] deferred atrium 320x180 camera 2" -> done 3, total 12, current.
struct ProgressLine {
  int64_t done = 0, total = 0;
  std::string current;
};
std::optional<ProgressLine> parseProgressLine(const std::string& line);

class Worker {
 public:
  Worker(store::Store& writer, WorkerOptions options);
  ~Worker();  // stop()
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  // Start-up: registers the host (refused while another live daemon holds its
  // name) and requeues this host's interrupted jobs; call before start().
  Result<store::Recovery> recover();
  void start();
  // Stops after the current step; a running child is killed and its job
  // queued again with the reason (Store::requeueJob), never left running.
  void stop();
  // Look at the queue now (a job was queued, or the daemon stops).
  void wake();

  // A host instance id: MACHINE:PID:RANDOM; and whether one is a dead
  // process of this machine (its name may then be taken over at once).
  static std::string newInstance();
  static bool instanceIsGone(const std::string& instance);

 private:
  void loop();
  store::JobWaiter* openWaiter(std::string& lastError);
  void heartbeatLoop();
  void runJob(const store::Job& job);
  // The daemon is stopping: the job goes back to the queue with the reason
  // (never left running), for this host's next start or another host.
  void requeueStopped(const store::Lease& lease, const std::string& why);
  // Records the job failed with its reason, retrying while the store refuses
  // writes; false when the daemon stopped first (the job is left running).
  bool recordFailure(const store::Lease& lease, const std::string& reason);
  // The `tallyd capture` child of a job: it reports progress, and stops when
  // the job is cancelled or its lease lost (cancelled is set) or the daemon stops.
  ChildOptions captureChild(const store::Job& job, const std::filesystem::path& specPath,
                            const std::filesystem::path& outPath, bool& cancelled);
  // Stores a result under the job's lease, retrying while the database is
  // unreachable; the error when it cannot (empty: stored and finished).
  std::string ingest(const store::Lease& lease, const nlohmann::json& result,
                     const std::map<std::string, std::vector<uint8_t>>& screenshots, bool sweep, int64_t* stored);
  void log(log::Level level, std::optional<int64_t> job, const std::string& message) const;

  store::Store& store_;
  WorkerOptions options_;
  std::thread thread_;
  std::thread heartbeat_;
  std::atomic<int64_t> currentJob_{0};   // 0: none
  std::atomic<int> currentAttempt_{0};
  std::atomic<bool> leaseLost_{false};   // the heartbeat found the job no longer ours
  std::atomic<bool> stopping_{false};
  std::mutex mutex_;
  std::condition_variable cv_;
  bool woken_ = false;
  std::unique_ptr<store::JobWaiter> waiter_;  // set and reset by loop(), under mutex_
};

}  // namespace tally::jobs
