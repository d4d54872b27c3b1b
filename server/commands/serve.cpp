// tallyd serve: the writer Store, the Worker, the HTTP server; stops cleanly
// on SIGINT/SIGTERM (a thread waits for them; the handler does nothing else).
#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <thread>

#include "api/builtin_routes.hpp"
#include "api/http_server.hpp"
#include "commands/commands.hpp"
#include "jobs/worker.hpp"
#include "renderers/options.hpp"
#include "renderers/renderer.hpp"
#include "service/service.hpp"
#include "store/store.hpp"

namespace tally::cli {

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

  auto writer = store::Store::open(args.db);
  if (!writer) {
    std::fprintf(stderr, "tallyd serve: %s: %s\n", args.db.c_str(), writer.error().c_str());
    return 1;
  }

  jobs::WorkerOptions workerOptions;
  workerOptions.tallydPath = self.string();
  workerOptions.device = args.device;
  workerOptions.deadline = std::chrono::seconds(args.jobDeadlineSeconds);
  jobs::Worker worker(**writer, workerOptions);
  if (auto recovered = worker.recover(); !recovered) {
    std::fprintf(stderr, "tallyd serve: recovery: %s\n", recovered.error().c_str());
    return 1;
  }

  service::ServiceContext context;
  context.writer = writer->get();
  context.dbPath = args.db;
  context.rendererNames = renderers::rendererNames();
  for (const auto& folder : args.scenes) context.options.sceneFolders.emplace_back(folder);
  context.onJobQueued = [&worker] { worker.wake(); };

  api::Router router;
  api::addBuiltinRoutes(router, renderers::rendererNames(), renderers::optionDefsJson(),
                        renderers::workloadNames());
  service::addServiceRoutes(router, context);

  api::ServerOptions options;
  options.bindAddress = args.bind;
  options.port = args.port;
  options.tokenFile = args.tokenFile;
  options.webRoot = args.web;
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
  std::fflush(stdout);
  (*server)->run();
  // Stopped by a signal, or the server ended on its own: wake the signal thread either way.
  pthread_kill(signals.native_handle(), SIGTERM);
  signals.join();
  worker.stop();
  std::fprintf(stderr, "tallyd: stopped\n");
  return 0;
}

}  // namespace tally::cli
