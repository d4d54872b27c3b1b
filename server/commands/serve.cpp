// tallyd serve: the writer Store, the Worker, the HTTP server; stops cleanly
// on SIGINT/SIGTERM (a thread waits for them; the handler does nothing else).
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <mutex>
#include <thread>
#include <utility>

#include "api/builtin_routes.hpp"
#include "api/http_server.hpp"
#include "commands/commands.hpp"
#include "common/log.hpp"
#include "common/metrics.hpp"
#include "common/paths.hpp"
#include "common/version.hpp"
#include "jobs/worker.hpp"
#include "renderers/options.hpp"
#include "renderers/renderer.hpp"
#include "service/service.hpp"
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
  m.declare("tally_device_info", Type::kGauge,
            "The capture device: the --device selector (\"auto\": the first discrete GPU) and the name of "
            "the device the last capture ran on (\"\" until one has); always 1");
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
  std::string webRoot = args.web;
  if (webRoot.empty()) {
    auto data = dataDirectory();
    if (!data || !fs::is_directory(*data / "web", ec)) {
      std::fprintf(stderr, "tallyd serve: no dashboard to serve (%s); give --web\n",
                   data ? ((*data / "web").string() + " is not a folder").c_str() : data.error().c_str());
      return 1;
    }
    webRoot = (*data / "web").string();
  }

  auto writer = store::Store::open(dbPath);
  if (!writer) {
    std::fprintf(stderr, "tallyd serve: %s: %s\n", dbPath.c_str(), writer.error().c_str());
    return 1;
  }

  metrics::Registry metrics;
  declareMetrics(metrics);
  metrics.set("tally_build_info", {{"version", std::string(version())}, {"commit", std::string(gitCommit())}}, 1);
  const std::string selector = args.device.empty() ? "auto" : args.device;
  metrics.set("tally_device_info", {{"selector", selector}, {"device", ""}}, 1);
  for (const char* status : {"done", "failed", "cancelled"}) metrics.add("tally_jobs_finished_total", {{"status", status}}, 0);
  std::mutex deviceMutex;

  jobs::WorkerOptions workerOptions;
  workerOptions.tallydPath = self.string();
  workerOptions.device = args.device;
  workerOptions.deadline = std::chrono::seconds(args.jobDeadlineSeconds);
  workerOptions.onFinished = [&](const jobs::JobOutcome& outcome) {
    metrics.add("tally_jobs_finished_total", {{"status", outcome.status}});
    metrics.observe("tally_capture_duration_seconds", {{"kind", outcome.kind}, {"status", outcome.status}},
                    outcome.seconds);
    if (!outcome.device.empty()) {
      std::lock_guard lock(deviceMutex);
      metrics.clear("tally_device_info");
      metrics.set("tally_device_info", {{"selector", selector}, {"device", outcome.device}}, 1);
    }
  };
  jobs::Worker worker(**writer, workerOptions);
  if (auto recovered = worker.recover(); !recovered) {
    std::fprintf(stderr, "tallyd serve: recovery: %s\n", recovered.error().c_str());
    return 1;
  }

  service::ServiceContext context;
  context.writer = writer->get();
  context.dbPath = dbPath;
  context.rendererNames = renderers::rendererNames();
  for (const auto& folder : args.scenes) context.options.sceneFolders.emplace_back(folder);
  context.options.allowApplications = args.allowApplications;
  context.onJobQueued = [&worker] { worker.wake(); };
  context.onQueuedJobCancelled = [&metrics](int64_t) {
    metrics.add("tally_jobs_finished_total", {{"status", "cancelled"}});
  };

  // Read at each scrape: the queue by state and the store's size on disk.
  metrics.onScrape([&](metrics::Registry& m) {
    auto counts = writer->get()->jobCounts();
    if (counts) {
      for (const auto& [state, n] : *counts) m.set("tally_jobs", {{"state", state}}, double(n));
    }
    for (const auto& [file, suffix] : {std::pair{"db", ""}, std::pair{"wal", "-wal"}, std::pair{"shm", "-shm"}}) {
      std::error_code sizeError;
      auto bytes = fs::file_size(dbPath + suffix, sizeError);
      m.set("tally_store_bytes", {{"file", file}}, sizeError ? 0.0 : double(bytes));
    }
  });

  api::Router router;
  api::addBuiltinRoutes(router, renderers::rendererNames(), renderers::optionDefsJson(),
                        renderers::workloadNames());
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
    return 1;
  }

  worker.start();
  std::thread signals([&] {
    int received = 0;
    sigwait(&stopSignals, &received);
    (*server)->stop();
  });
  std::printf("tallyd: serving http://%s:%d/\n", args.bind.c_str(), (*server)->port());
  std::printf("tallyd: database %s, dashboard %s\n", dbPath.c_str(), webRoot.c_str());
  std::fflush(stdout);
  log::info(versionLine("tallyd") + " serving http://" + args.bind + ":" + std::to_string((*server)->port()) +
            "/ database " + dbPath + " dashboard " + webRoot + " device " + selector);
  (*server)->run();
  // Stopped by a signal, or the server ended on its own: wake the signal thread either way.
  pthread_kill(signals.native_handle(), SIGTERM);
  signals.join();
  worker.stop();
  log::info("stopped");
  return 0;
}

}  // namespace tally::cli
