// tallyd serve: the writer Store, the Worker, the HTTP server; stops cleanly
// on SIGINT/SIGTERM (a thread waits for them; the handler does nothing else).
// --role picks the parts: api (HTTP only), worker (the Worker only, as one
// host of a fleet sharing a PostgreSQL store), all (both; docs/fleet.md).
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <filesystem>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <utility>

#include "api/auth.hpp"
#include "api/builtin_routes.hpp"
#include "api/http_post.hpp"
#include "api/http_server.hpp"
#include "capture/application_policy.hpp"
#include "commands/commands.hpp"
#include "common/log.hpp"
#include "common/metrics.hpp"
#include "common/paths.hpp"
#include "common/version.hpp"
#include "common/child_process.hpp"
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

// The device this worker captures on, probed in a child process (a broken
// driver ends the probe, not the daemon): `tallyd device --json`. Null, with
// a warning, when there is none: the worker then takes only jobs that name
// no device.
nlohmann::json probeDevice(const std::string& self, const std::string& selector) {
  char path[] = "/tmp/tally-device-XXXXXX";
  int fd = mkstemp(path);
  if (fd < 0) return nullptr;
  close(fd);
  jobs::ChildOptions child;
  child.argv = {self, "device", "--json"};
  if (!selector.empty()) child.argv.insert(child.argv.end(), {"--device", selector});
  child.deadline = std::chrono::seconds(60);
  child.stdoutPath = path;
  auto ran = jobs::runChild(child);
  nlohmann::json device;
  if (ran && ran->ok()) {
    std::ifstream in(path);
    device = nlohmann::json::parse(in, nullptr, false);
    if (device.is_discarded() || !device.is_object()) device = nullptr;
  }
  if (device.is_null()) {
    log::warning(std::string("no capture device found (") + (ran ? ran->reason() : ran.error()) +
                 "); this worker takes only jobs that name no device");
  }
  std::filesystem::remove(path);
  return device;
}


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

// The rules for running applications (docs/operating.md, "Security model"),
// checked before anything starts: --allow-applications needs an application
// token (to serve the API), roots, and a user to run them as when tallyd is
// root (to run them). Returns the policy, and the arguments every capture
// child gets so that it checks each spec again where it runs.
struct ApplicationSetup {
  capture::ApplicationPolicy policy;
  std::vector<std::string> captureArgs;
};

Result<ApplicationSetup> applicationSetup(const ServeArgs& args, bool serveHttp, bool runWorker) {
  ApplicationSetup setup;
  setup.captureArgs = {"--confine-applications"};
  if (!args.allowApplications) {
    if (!args.applicationRoots.empty() || !args.applicationEnv.empty() || !args.runAs.empty()) {
      return makeError("--application-root, --application-env and --run-as go with --allow-applications");
    }
    return setup;  // the capture child refuses every application spec: no roots
  }
  if (serveHttp) {
    const std::string how =
        "a token file with an application=<token> line beside read= and capture= (e.g. from "
        "`openssl rand -hex 32`): only its holders may run applications";
    if (args.tokenFile.empty()) return makeError("--allow-applications needs --token-file: " + how);
    auto tokens = api::loadTokenFile(args.tokenFile);
    if (!tokens) return makeError(tokens.error());
    if (tokens->application.empty()) {
      return makeError("--allow-applications: " + args.tokenFile +
                       " has no application=<token> line; it needs " + how);
    }
  }
  if (args.applicationRoots.empty()) {
    return makeError(
        "--allow-applications needs at least one --application-root DIR: the folders an application's "
        "program or a replay file must lie in (links followed), e.g. /opt/tally-apps");
  }
  auto roots = capture::checkApplicationRoots(args.applicationRoots);
  if (!roots) return makeError(roots.error());
  setup.policy.roots = *roots;
  for (const auto& pattern : args.applicationEnv) {
    if (auto checked = capture::checkApplicationEnvPattern(pattern); !checked)
      return makeError(checked.error());
    setup.policy.env.push_back(pattern);
  }
  if (!args.runAs.empty()) {
    if (geteuid() != 0) {
      return makeError("--run-as " + args.runAs +
                       ": tallyd runs as a user of its own already (not root), and applications run as that "
                       "user; drop --run-as");
    }
    auto user = jobs::lookupUser(args.runAs);
    if (!user) return makeError("--run-as: " + user.error());
  } else if (runWorker && geteuid() == 0) {
    return makeError(
        "refusing to run applications as root: give --run-as USER, an unprivileged user they run as "
        "(useradd --system --no-create-home tally-apps), or start tallyd as a user of its own (the "
        "systemd unit's DynamicUser=yes does: docs/operating.md, \"Security model\")");
  }
  for (const auto& root : setup.policy.roots) {
    setup.captureArgs.insert(setup.captureArgs.end(), {"--application-root", root.string()});
  }
  for (const auto& pattern : setup.policy.env) {
    setup.captureArgs.insert(setup.captureArgs.end(), {"--application-env", pattern});
  }
  if (!args.runAs.empty()) setup.captureArgs.insert(setup.captureArgs.end(), {"--run-as", args.runAs});
  return setup;
}

}  // namespace

int runServe(const ServeArgs& args) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) {
    std::fprintf(stderr, "tallyd serve: cannot find this executable: %s\n", ec.message().c_str());
    return 1;
  }
  for (const auto& folder : args.scenes) {
    if (!fs::is_directory(folder, ec)) {
      std::fprintf(stderr, "tallyd serve: --scenes %s: not a folder\n", folder.c_str());
      return 1;
    }
  }

  // Block the stop signals in every thread; one thread takes them with sigwait.
  sigset_t stopSignals;
  sigemptyset(&stopSignals);
  sigaddset(&stopSignals, SIGINT);
  sigaddset(&stopSignals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stopSignals, nullptr);
  signal(SIGPIPE, SIG_IGN);

  const bool serveHttp = args.role != "worker";
  const bool runWorker = args.role != "api";
  auto applications = applicationSetup(args, serveHttp, runWorker);
  if (!applications) {
    std::fprintf(stderr, "tallyd serve: %s\n", applications.error().c_str());
    return 1;
  }
  if (!args.alertWebhook.empty()) {
    auto target = api::parseHttpUrl(args.alertWebhook);
    if (!target) {
      std::fprintf(stderr, "tallyd serve: --alert-webhook %s: %s\n", args.alertWebhook.c_str(), target.error().c_str());
      return 1;
    }
    if (!serveHttp) {
      std::fprintf(stderr, "tallyd serve: --alert-webhook is for daemons that serve the API (role api or all)\n");
      return 1;
    }
  }
  const bool postgres = store::isPostgresUrl(args.db);

  // The defaults: the user's data folder for the database, the installed
  // dashboard (the unit passes --db /var/lib/tally/tally.db).
  std::string dbPath = args.db;
  if (dbPath.empty()) {
    auto state = userDataDirectory();
    if (!state) {
      std::fprintf(stderr, "tallyd serve: %s\n", state.error().c_str());
      return 1;
    }
    fs::create_directories(*state, ec);
    if (ec) {
      std::fprintf(stderr, "tallyd serve: cannot create %s: %s\n", state->c_str(), ec.message().c_str());
      return 1;
    }
    dbPath = (*state / "tally.db").string();
  }
  const std::string dbName = postgres ? store::redactUrl(dbPath) : dbPath;
  std::string webRoot = args.web;
  if (webRoot.empty() && serveHttp) {
    auto data = dataDirectory();
    if (!data || !fs::is_directory(*data / "web", ec)) {
      std::fprintf(stderr, "tallyd serve: no dashboard to serve (%s); give --web\n",
                   data ? ((*data / "web").string() + " is not a folder").c_str() : data.error().c_str());
      return 1;
    }
    webRoot = (*data / "web").string();
  }
  std::string hostName = args.hostName;
  if (hostName.empty()) {
    char name[256] = {};
    gethostname(name, sizeof name - 1);
    hostName = name;
  }

  auto writer = store::Store::open(dbPath);
  if (!writer) {
    std::fprintf(stderr, "tallyd serve: %s: %s\n", dbName.c_str(), writer.error().c_str());
    return 1;
  }

  // The store's health: checked now, before any job runs, then on a
  // schedule on a thread and connection of its own. A damaged store still
  // serves what it can read and says what is wrong (/api/health 503), but
  // takes no job: the worker does not start.
  service::StoreHealthOptions healthOptions;
  healthOptions.location = dbPath;
  healthOptions.checkInterval = std::chrono::seconds(args.storeCheckSeconds);
  healthOptions.log = [](std::string_view line) { log::warning(std::string(line)); };
  service::StoreHealth storeHealth(healthOptions);
  storeHealth.checkNow();
  const bool damagedAtStart = storeHealth.state().fault == store::Fault::kDamaged;
  if (damagedAtStart) {
    log::error("the store is damaged (" + storeHealth.state().reason +
               "); serving what can be read, taking no jobs until it is repaired");
  }

  metrics::Registry metrics;
  declareMetrics(metrics);
  metrics.set("tally_build_info", {{"version", std::string(version())}, {"commit", std::string(gitCommit())}}, 1);
  const std::string selector = args.device.empty() ? "auto" : args.device;
  metrics.set("tally_device_info", {{"selector", selector}, {"device", ""}}, 1);
  for (const char* status : {"done", "failed", "cancelled"}) metrics.add("tally_jobs_finished_total", {{"status", status}}, 0);
  std::mutex deviceMutex;

  const auto lease = std::chrono::milliseconds(int64_t(args.leaseSeconds * 1000));
  const auto staleAfter = std::chrono::milliseconds(int64_t(args.staleSeconds * 1000));
  jobs::WorkerOptions workerOptions;
  workerOptions.tallydPath = self.string();
  workerOptions.device = args.device;
  workerOptions.captureArgs = applications->captureArgs;
  workerOptions.deadline = std::chrono::seconds(args.jobDeadlineSeconds);
  workerOptions.maxAttempts = args.maxAttempts;
  workerOptions.lease = lease;
  workerOptions.staleAfter = staleAfter;
  workerOptions.openHeartbeatStore = [dbPath] { return store::Store::open(dbPath); };
  workerOptions.onStoreFault = [&storeHealth](store::Fault fault, const std::string& detail) {
    storeHealth.noteFault(fault, detail);
  };
  // Alerts (role api or all): new runs against their baselines, and the
  // webhook's outbox, each on its own thread and connection; workers never
  // wait on them.
  service::AlertEvaluator::Options evaluatorOptions;
  evaluatorOptions.location = dbPath;
  evaluatorOptions.deliver = !args.alertWebhook.empty();
  evaluatorOptions.log = [](std::string_view line) { log::info(std::string(line)); };
  metrics.add("tally_alerts_raised_total", {}, 0);
  evaluatorOptions.onEvaluated = [&metrics](const store::Evaluated& done) {
    metrics.add("tally_alerts_raised_total", {}, double(done.alertIds.size()));
  };
  service::AlertEvaluator evaluator(evaluatorOptions);
  service::WebhookOptions webhookOptions;
  webhookOptions.url = args.alertWebhook;
  webhookOptions.dashboardUrl = args.dashboardUrl;
  webhookOptions.maxAttempts = args.alertWebhookAttempts;
  service::WebhookSender webhook(dbPath, webhookOptions, [](std::string_view line) { log::warning(std::string(line)); });
  workerOptions.onFinished = [&](const jobs::JobOutcome& outcome) {
    if (serveHttp) evaluator.wake();
    metrics.add("tally_jobs_finished_total", {{"status", outcome.status}});
    metrics.observe("tally_capture_duration_seconds", {{"kind", outcome.kind}, {"status", outcome.status}},
                    outcome.seconds);
    if (!outcome.device.empty()) {
      std::lock_guard lock(deviceMutex);
      metrics.clear("tally_device_info");
      metrics.set("tally_device_info", {{"selector", selector}, {"device", outcome.device}}, 1);
    }
  };
  if (runWorker) {
    workerOptions.host.name = hostName;
    workerOptions.host.instance = jobs::Worker::newInstance();
    workerOptions.host.role = args.role;
    workerOptions.host.tallyVersion = std::string(version());
    workerOptions.host.tallyCommit = std::string(gitCommit());
    workerOptions.host.device = probeDevice(self.string(), args.device);
    if (!args.deviceNameOverride.empty()) {
      workerOptions.deviceNameOverride = args.deviceNameOverride;
      workerOptions.host.deviceOverride = args.deviceNameOverride;
      if (workerOptions.host.device.is_object()) {
        workerOptions.host.device["name_reported"] = workerOptions.host.device.value("name", "");
        workerOptions.host.device["name"] = args.deviceNameOverride;
      }
    }
  }
  jobs::Worker worker(**writer, workerOptions);
  const bool startWorker = runWorker && !damagedAtStart;
  if (startWorker) {
    if (auto recovered = worker.recover(); !recovered) {
      std::fprintf(stderr, "tallyd serve: %s\n", recovered.error().c_str());
      return 1;
    }
  }

  // Without a worker here, something must still notice workers that died:
  // the API daemon reaps expired leases on the worker's schedule.
  std::mutex reaperMutex;
  std::condition_variable reaperWake;
  bool reaperStop = false;
  std::thread reaper;
  if (!runWorker) {
    reaper = std::thread([&] {
      auto store = store::Store::open(dbPath);
      std::unique_lock lock(reaperMutex);
      while (!reaperStop) {
        if (store) {
          lock.unlock();
          auto reaped = (*store)->requeueExpired();
          if (reaped) {
            for (int64_t id : reaped->requeued) log::warning("lease expired; queued again", id);
            for (int64_t id : reaped->failed) log::error("lease expired on its last attempt; failed", id);
          }
          lock.lock();
        }
        reaperWake.wait_for(lock, std::max(lease / 3, std::chrono::milliseconds(100)), [&] { return reaperStop; });
      }
    });
  }
  auto stopReaper = [&] {
    {
      std::lock_guard lock(reaperMutex);
      reaperStop = true;
    }
    reaperWake.notify_all();
    if (reaper.joinable()) reaper.join();
  };

  storeHealth.start();
  if (!serveHttp) {
    if (startWorker) worker.start();
    std::printf("tallyd: worker %s on %s, database %s\n", hostName.c_str(),
                workerOptions.host.device.is_object() ? workerOptions.host.device.value("name", "").c_str() : "no device",
                dbName.c_str());
    std::fflush(stdout);
    log::info(versionLine("tallyd") + " worker " + hostName + " database " + dbName + " device " + selector);
    int received = 0;
    sigwait(&stopSignals, &received);
    worker.stop();
    log::info("stopped");
    return 0;
  }

  service::ServiceContext context;
  context.writer = writer->get();
  context.dbPath = dbPath;
  context.rendererNames = renderers::rendererNames();
  for (const auto& folder : args.scenes) context.options.sceneFolders.emplace_back(folder);
  context.options.allowApplications = args.allowApplications;
  context.options.applicationPolicy = applications->policy;
  context.options.staleAfterMs = staleAfter.count();
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
    metrics.add("tally_jobs_finished_total", {{"status", "cancelled"}});
  };

  // Read at each scrape: the queue by state and the store's size on disk.
  metrics.onScrape([&](metrics::Registry& m) {
    const service::StoreHealth::State health = storeHealth.state();
    m.set("tally_store_up", {}, health.fault == store::Fault::kNone ? 1 : 0);
    m.clear("tally_store_fault");
    if (health.fault != store::Fault::kNone)
      m.set("tally_store_fault", {{"fault", store::toString(health.fault)}}, 1);
    m.set("tally_store_check_seconds", {}, health.checkSeconds);
    auto counts = writer->get()->jobCounts();
    if (counts) {
      for (const auto& [state, n] : *counts) m.set("tally_jobs", {{"state", state}}, double(n));
    }
    auto alerts = writer->get()->alertCounts();
    if (alerts) {
      for (const auto& [status, n] : *alerts) m.set("tally_alerts", {{"status", status}}, double(n));
    }
    if (postgres) return;  // the server's files are not this host's
    for (const auto& [file, suffix] : {std::pair{"db", ""}, std::pair{"wal", "-wal"}, std::pair{"shm", "-shm"}}) {
      std::error_code sizeError;
      auto bytes = fs::file_size(dbPath + suffix, sizeError);
      m.set("tally_store_bytes", {{"file", file}}, sizeError ? 0.0 : double(bytes));
    }
  });

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
  options.webRoot = webRoot;
  options.requestTimeout = std::chrono::milliseconds(int64_t(args.requestTimeoutSeconds * 1000));
  options.maxConnectionsPerPeer = size_t(args.maxConnectionsPerPeer);
  options.metrics = &metrics;
  auto server = api::HttpServer::create(options, std::move(router));
  if (!server) {
    std::fprintf(stderr, "tallyd serve: %s\n", server.error().c_str());
    stopReaper();
    return 1;
  }

  if (startWorker) worker.start();
  evaluator.start();
  if (!args.alertWebhook.empty()) webhook.start();
  std::thread signals([&] {
    int received = 0;
    sigwait(&stopSignals, &received);
    (*server)->stop();
    // At once, beside the requests still being answered: the capture is
    // killed and its job queued again (docs/operating.md, "Stopping").
    worker.stop();
  });
  std::printf("tallyd: serving http://%s:%d/\n", args.bind.c_str(), (*server)->port());
  std::printf("tallyd: database %s, dashboard %s\n", dbName.c_str(), webRoot.c_str());
  std::fflush(stdout);
  log::info(versionLine("tallyd") + " serving http://" + args.bind + ":" + std::to_string((*server)->port()) +
            "/ database " + dbName + " dashboard " + webRoot + " role " + args.role +
            (runWorker ? " host " + hostName + " device " + selector : std::string()));
  (*server)->run();
  // Stopped by a signal, or the server ended on its own: wake the signal thread either way.
  pthread_kill(signals.native_handle(), SIGTERM);
  signals.join();
  worker.stop();
  webhook.stop();
  evaluator.stop();
  storeHealth.stop();
  stopReaper();
  log::info("stopped");
  return 0;
}

}  // namespace tally::cli
