// tallyd serve: the writer Store, the Worker, the HTTP server; stops cleanly
// on SIGINT/SIGTERM (a thread waits for them; the handler does nothing else).
// --role picks the parts: api (HTTP only), worker (the Worker only, as one
// host of a fleet sharing a PostgreSQL store), all (both; docs/fleet.md).
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <thread>
#include <utility>

#include "api/builtin_routes.hpp"
#include "api/http_server.hpp"
#include "commands/commands.hpp"
#include "commands/serve_setup.hpp"
#include "common/log.hpp"
#include "common/metrics.hpp"
#include "common/version.hpp"
#include "jobs/worker.hpp"
#include "renderers/options.hpp"
#include "renderers/renderer.hpp"
#include "service/alert_evaluator.hpp"
#include "service/service.hpp"
#include "service/store_health.hpp"
#include "service/webhook.hpp"
#include "store/store.hpp"

namespace tally::cli {
namespace {

// The daemon's own families (the HTTP server declares its own).
void declareMetrics(metrics::Registry& m) {
  using metrics::Type;
  m.declare("tally_build_info", Type::kGauge, "The build serving: version and git commit (always 1)");
  m.declare("tally_jobs", Type::kGauge, "Capture jobs in the store, by state (queue depth: queued, running)");
  m.declare("tally_jobs_finished_total", Type::kCounter,
            "Jobs that ended since the daemon started, by status (done, failed, cancelled)");
  m.declare("tally_capture_duration_seconds", Type::kHistogram,
            "Time from claiming a job to its end, by kind (capture, sweep) and status", metrics::kCaptureSeconds);
  m.declare("tally_store_bytes", Type::kGauge, "Size of the SQLite store on disk, by file (db, wal, shm)");
  m.declare("tally_alerts", Type::kGauge, "Regression alerts in the store, by status (open, acknowledged, invalid, fixed)");
  m.declare("tally_alerts_raised_total", Type::kCounter,
            "Regression alerts this daemon's evaluator raised since it started");
  m.declare("tally_captures_limited_total", Type::kCounter,
            "POST /api/captures answered 429 by a queue limit, by limit (queue: --max-queued, client: "
            "--max-queued-per-client)");
  m.declare("tally_queue_limit", Type::kGauge,
            "The queue's limits, by limit (queue: --max-queued, client: --max-queued-per-client; 0: none)");
  m.declare("tally_store_up", Type::kGauge,
            "1 while the store is healthy: its last check passed and no fault is open (docs/operating.md)");
  m.declare("tally_store_fault", Type::kGauge,
            "The store's open fault, by kind (damaged, full, io_error, read_only, unreachable); always 1");
  m.declare("tally_store_check_seconds", Type::kGauge,
            "How long the store's last health check took (SQLite quick_check, PostgreSQL round trip)");
  m.declare("tally_device_info", Type::kGauge,
            "The capture device: the --device selector (\"auto\": the first discrete GPU) and the name of "
            "the device the last capture ran on (\"\" until one has); always 1");
}

// Blocks the stop signals in every thread (the calling one, and every thread
// started after); one thread takes them with sigwait.
sigset_t blockStopSignals() {
  sigset_t stopSignals;
  sigemptyset(&stopSignals);
  sigaddset(&stopSignals, SIGINT);
  sigaddset(&stopSignals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stopSignals, nullptr);
  signal(SIGPIPE, SIG_IGN);
  return stopSignals;
}

// The store's health: checked now, before any job runs, then on a schedule
// on a thread and connection of its own. A damaged store still serves what
// it can read and says what is wrong (/api/health 503), but takes no job:
// the worker does not start. True when it is damaged now.
bool checkStoreAtStart(service::StoreHealth& storeHealth) {
  storeHealth.checkNow();
  const bool damaged = storeHealth.state().fault == store::Fault::kDamaged;
  if (damaged) {
    log::error("the store is damaged (" + storeHealth.state().reason +
               "); serving what can be read, taking no jobs until it is repaired");
  }
  return damaged;
}

service::StoreHealthOptions storeHealthOptions(const ServeArgs& args, const ServeSetup& setup) {
  service::StoreHealthOptions options;
  options.location = setup.dbPath;
  options.checkInterval = std::chrono::seconds(args.storeCheckSeconds);
  options.log = [](std::string_view line) { log::warning(std::string(line)); };
  return options;
}

void startMetrics(metrics::Registry& metrics, const ServeSetup& setup) {
  declareMetrics(metrics);
  metrics.set("tally_build_info", {{"version", std::string(version())}, {"commit", std::string(gitCommit())}}, 1);
  metrics.set("tally_device_info", {{"selector", setup.selector}, {"device", ""}}, 1);
  for (store::JobStatus status : store::kJobStatuses) {
    if (store::isFinal(status)) metrics.add("tally_jobs_finished_total", {{"status", store::toString(status)}}, 0);
  }
}

// The worker's options but for its callbacks and its host.
jobs::WorkerOptions makeWorkerOptions(const ServeArgs& args, const ServeSetup& setup) {
  jobs::WorkerOptions options;
  options.tallydPath = setup.self;
  options.device = args.device;
  options.captureArgs = setup.applications.captureArgs;
  options.deadline = std::chrono::seconds(args.jobDeadlineSeconds);
  options.maxAttempts = args.maxAttempts;
  options.lease = setup.lease;
  options.staleAfter = setup.staleAfter;
  const std::string dbPath = setup.dbPath;
  options.openHeartbeatStore = [dbPath] { return store::Store::open(dbPath); };
  return options;
}

// Alerts (role api or all): new runs against their baselines, and the
// webhook's outbox, each on its own thread and connection; workers never
// wait on them.
service::AlertEvaluator::Options alertEvaluatorOptions(const ServeArgs& args, const ServeSetup& setup,
                                                       metrics::Registry& metrics) {
  service::AlertEvaluator::Options options;
  options.location = setup.dbPath;
  options.deliver = !args.alertWebhook.empty();
  options.log = [](std::string_view line) { log::info(std::string(line)); };
  metrics.add("tally_alerts_raised_total", {}, 0);
  options.onEvaluated = [&metrics](const store::Evaluated& done) {
    metrics.add("tally_alerts_raised_total", {}, double(done.alertIds.size()));
  };
  return options;
}

service::WebhookOptions webhookOptions(const ServeArgs& args) {
  service::WebhookOptions options;
  options.url = args.alertWebhook;
  options.dashboardUrl = args.dashboardUrl;
  options.maxAttempts = args.alertWebhookAttempts;
  return options;
}

// Without a worker here, something must still notice workers that died:
// the API daemon reaps expired leases on the worker's schedule.
class LeaseReaper {
 public:
  ~LeaseReaper() { stop(); }

  void start(const std::string& dbPath, std::chrono::milliseconds lease) {
    thread_ = std::thread([this, dbPath, lease] {
      auto store = store::Store::open(dbPath);
      std::unique_lock lock(mutex_);
      while (!stop_) {
        if (store) {
          lock.unlock();
          auto reaped = (*store)->jobs().requeueExpired();
          if (reaped) {
            for (int64_t id : reaped->requeued) log::warning("lease expired; queued again", id);
            for (int64_t id : reaped->failed) log::error("lease expired on its last attempt; failed", id);
          }
          lock.lock();
        }
        wake_.wait_for(lock, std::max(lease / 3, std::chrono::milliseconds(100)), [&] { return stop_; });
      }
    });
  }

  void stop() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

// Role worker: runs jobs until a stop signal.
int runWorkerOnly(jobs::Worker& worker, bool startWorker, const store::HostInfo& host, const ServeSetup& setup,
                  const sigset_t& stopSignals) {
  if (startWorker) worker.start();
  std::printf("tallyd: worker %s on %s, database %s\n", setup.hostName.c_str(),
              host.device.is_object() ? host.device.value("name", "").c_str() : "no device", setup.dbName.c_str());
  std::fflush(stdout);
  log::info(versionLine("tallyd") + " worker " + setup.hostName + " database " + setup.dbName + " device " +
            setup.selector);
  int received = 0;
  sigwait(&stopSignals, &received);
  worker.stop();
  log::info("stopped");
  return 0;
}

service::ServiceContext serviceContext(const ServeArgs& args, const ServeSetup& setup, store::Store* writer,
                                       service::StoreHealth& storeHealth, jobs::Worker& worker,
                                       metrics::Registry& metrics) {
  service::ServiceContext context;
  context.writer = writer;
  context.dbPath = setup.dbPath;
  context.rendererNames = renderers::rendererNames();
  for (const auto& folder : args.scenes) context.options.sceneFolders.emplace_back(folder);
  context.options.allowApplications = args.allowApplications;
  context.options.applicationPolicy = setup.applications.policy;
  context.options.staleAfterMs = setup.staleAfter.count();
  context.options.maxAttempts = args.maxAttempts;
  context.options.maxQueued = args.maxQueued;
  context.options.maxQueuedPerClient = args.maxQueuedPerClient;
  context.options.maxCost = uint64_t(args.maxCost);
  for (const char* limit : {"queue", "client"})
    metrics.add("tally_captures_limited_total", {{"limit", limit}}, 0);
  metrics.set("tally_queue_limit", {{"limit", "queue"}}, double(args.maxQueued));
  metrics.set("tally_queue_limit", {{"limit", "client"}}, double(args.maxQueuedPerClient));
  context.onQueueLimited = [&metrics](const std::string& limit) {
    metrics.add("tally_captures_limited_total", {{"limit", limit}});
  };
  context.onJobQueued = [&worker] { worker.wake(); };
  context.health = &storeHealth;
  context.onQueuedJobCancelled = [&metrics](int64_t) {
    metrics.add("tally_jobs_finished_total", {{"status", store::toString(store::JobStatus::Cancelled)}});
  };
  return context;
}

// Read at each scrape: the store's health, the queue by state, the alerts by
// status and the store's size on disk.
void scrapeStore(metrics::Registry& metrics, service::StoreHealth& storeHealth, store::Store* writer,
                 const ServeSetup& setup) {
  metrics.onScrape([&storeHealth, writer, postgres = setup.postgres, dbPath = setup.dbPath](metrics::Registry& m) {
    const service::StoreHealth::State health = storeHealth.state();
    m.set("tally_store_up", {}, health.fault == store::Fault::kNone ? 1 : 0);
    m.clear("tally_store_fault");
    if (health.fault != store::Fault::kNone)
      m.set("tally_store_fault", {{"fault", store::toString(health.fault)}}, 1);
    m.set("tally_store_check_seconds", {}, health.checkSeconds);
    auto counts = writer->jobs().counts();
    if (counts) {
      for (const auto& [state, n] : *counts) m.set("tally_jobs", {{"state", state}}, double(n));
    }
    auto alerts = writer->alerts().counts();
    if (alerts) {
      for (const auto& [status, n] : *alerts) m.set("tally_alerts", {{"status", status}}, double(n));
    }
    if (postgres) return;  // the server's files are not this host's
    for (const auto& [file, suffix] : {std::pair{"db", ""}, std::pair{"wal", "-wal"}, std::pair{"shm", "-shm"}}) {
      std::error_code sizeError;
      auto bytes = std::filesystem::file_size(dbPath + suffix, sizeError);
      m.set("tally_store_bytes", {{"file", file}}, sizeError ? 0.0 : double(bytes));
    }
  });
}

Result<std::unique_ptr<api::HttpServer>> createHttpServer(const ServeArgs& args, const ServeSetup& setup,
                                                          service::ServiceContext& context,
                                                          service::StoreHealth& storeHealth,
                                                          metrics::Registry& metrics) {
  api::Router router;
  api::addBuiltinRoutes(router, renderers::rendererNames(), renderers::optionDefsJson(),
                        renderers::workloadNames(), [&storeHealth] { return storeHealth.toJson(); });
  service::addServiceRoutes(router, context);
  router.get("/metrics", [&metrics](const api::Request&) {
    return api::Response::raw(metrics.text(), "text/plain; version=0.0.4; charset=utf-8");
  });

  api::ServerOptions options;
  options.bindAddress = args.bind;
  options.port = args.port;
  options.tokenFile = args.tokenFile;
  options.webRoot = setup.webRoot;
  options.requestTimeout = std::chrono::milliseconds(int64_t(args.requestTimeoutSeconds * 1000));
  options.maxConnectionsPerPeer = size_t(args.maxConnectionsPerPeer);
  options.metrics = &metrics;
  return api::HttpServer::create(options, std::move(router));
}

// Serves until a stop signal, or until the server ends on its own.
void serveUntilStopped(api::HttpServer& server, jobs::Worker& worker, const sigset_t& stopSignals,
                       const ServeArgs& args, const ServeSetup& setup) {
  std::thread signals([&] {
    int received = 0;
    sigwait(&stopSignals, &received);
    server.stop();
    // At once, beside the requests still being answered: the capture is
    // killed and its job queued again (docs/operating.md, "Stopping").
    worker.stop();
  });
  std::printf("tallyd: serving http://%s:%d/\n", args.bind.c_str(), server.port());
  std::printf("tallyd: database %s, dashboard %s\n", setup.dbName.c_str(), setup.webRoot.c_str());
  std::fflush(stdout);
  log::info(versionLine("tallyd") + " serving http://" + args.bind + ":" + std::to_string(server.port()) +
            "/ database " + setup.dbName + " dashboard " + setup.webRoot + " role " + args.role +
            (setup.runWorker ? " host " + setup.hostName + " device " + setup.selector : std::string()));
  server.run();
  // Stopped by a signal, or the server ended on its own: wake the signal thread either way.
  pthread_kill(signals.native_handle(), SIGTERM);
  signals.join();
}

}  // namespace

int runServe(const ServeArgs& args) {
  std::error_code ec;
  std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) {
    std::fprintf(stderr, "tallyd serve: cannot find this executable: %s\n", ec.message().c_str());
    return 1;
  }
  for (const auto& folder : args.scenes) {
    if (!std::filesystem::is_directory(folder, ec)) {
      std::fprintf(stderr, "tallyd serve: --scenes %s: not a folder\n", folder.c_str());
      return 1;
    }
  }
  const sigset_t stopSignals = blockStopSignals();
  auto setup = resolveServeSetup(args, self.string());
  if (!setup) {
    std::fprintf(stderr, "tallyd serve: %s\n", setup.error().c_str());
    return 1;
  }

  auto writer = store::Store::open(setup->dbPath);
  if (!writer) {
    std::fprintf(stderr, "tallyd serve: %s: %s\n", setup->dbName.c_str(), writer.error().c_str());
    return 1;
  }
  service::StoreHealth storeHealth(storeHealthOptions(args, *setup));
  const bool damagedAtStart = checkStoreAtStart(storeHealth);

  metrics::Registry metrics;
  startMetrics(metrics, *setup);
  std::mutex deviceMutex;

  jobs::WorkerOptions workerOptions = makeWorkerOptions(args, *setup);
  workerOptions.onStoreFault = [&storeHealth](store::Fault fault, const std::string& detail) {
    storeHealth.noteFault(fault, detail);
  };
  service::AlertEvaluator evaluator(alertEvaluatorOptions(args, *setup, metrics));
  service::WebhookSender webhook(setup->dbPath, webhookOptions(args),
                                 [](std::string_view line) { log::warning(std::string(line)); });
  workerOptions.onFinished = [&](const jobs::JobOutcome& outcome) {
    if (setup->serveHttp) evaluator.wake();
    metrics.add("tally_jobs_finished_total", {{"status", outcome.status}});
    metrics.observe("tally_capture_duration_seconds", {{"kind", outcome.kind}, {"status", outcome.status}},
                    outcome.seconds);
    if (!outcome.device.empty()) {
      std::lock_guard lock(deviceMutex);
      metrics.clear("tally_device_info");
      metrics.set("tally_device_info", {{"selector", setup->selector}, {"device", outcome.device}}, 1);
    }
  };
  if (setup->runWorker) {
    workerOptions.host = workerHost(args, *setup);
    if (!args.deviceNameOverride.empty()) workerOptions.deviceNameOverride = args.deviceNameOverride;
  }
  jobs::Worker worker(**writer, workerOptions);
  const bool startWorker = setup->runWorker && !damagedAtStart;
  if (startWorker) {
    if (auto recovered = worker.recover(); !recovered) {
      std::fprintf(stderr, "tallyd serve: %s\n", recovered.error().c_str());
      return 1;
    }
  }

  LeaseReaper reaper;
  if (!setup->runWorker) reaper.start(setup->dbPath, setup->lease);

  storeHealth.start();
  if (!setup->serveHttp) return runWorkerOnly(worker, startWorker, workerOptions.host, *setup, stopSignals);

  service::ServiceContext context = serviceContext(args, *setup, writer->get(), storeHealth, worker, metrics);
  scrapeStore(metrics, storeHealth, writer->get(), *setup);
  auto server = createHttpServer(args, *setup, context, storeHealth, metrics);
  if (!server) {
    std::fprintf(stderr, "tallyd serve: %s\n", server.error().c_str());
    reaper.stop();
    return 1;
  }

  if (startWorker) worker.start();
  evaluator.start();
  if (!args.alertWebhook.empty()) webhook.start();
  serveUntilStopped(**server, worker, stopSignals, args, *setup);
  worker.stop();
  webhook.stop();
  evaluator.stop();
  storeHealth.stop();
  reaper.stop();
  log::info("stopped");
  return 0;
}

}  // namespace tally::cli
