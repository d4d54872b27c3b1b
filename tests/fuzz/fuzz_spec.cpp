// A capture spec into the parser and admission: the body as the HTTP layer
// parses it (api::parseJsonBody), then POST /api/captures through the
// service's routes (service::addServiceRoutes, api::Router::dispatch), which
// checks it with capture::parseCaptureSpec (or the sweep and application
// parsers) against the server's limits and queues it in a store in memory.
// Bad input must be answered 4xx: a 500 (an exception escaping the parsers)
// is a finding.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string_view>

#include "api/request_checks.hpp"
#include "api/router.hpp"
#include "renderers/renderer.hpp"
#include "service/service.hpp"
#include "store/store.hpp"

namespace {

using namespace tally;

struct Daemon {
  std::unique_ptr<store::Store> store;
  service::ServiceContext context;
  api::Router router;
  int queued = 0;

  Daemon() {
    auto opened = store::Store::open(":memory:");
    if (!opened.ok()) {
      std::fprintf(stderr, "fuzz_spec: %s\n", opened.error().c_str());
      std::abort();
    }
    store = std::move(*opened);
    context.writer = store.get();
    context.dbPath = ":memory:";
    context.rendererNames = renderers::rendererNames();
    service::addServiceRoutes(router, context);
  }
};

std::unique_ptr<Daemon> instance;

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto body = api::parseJsonBody(std::string_view(reinterpret_cast<const char*>(data), size));
  if (!body.ok()) return 0;
  // A fresh store now and then, so that the queued jobs do not pile up.
  if (!instance || instance->queued >= 4096) instance = std::make_unique<Daemon>();
  api::Request request;
  request.method = "POST";
  request.path = "/api/captures";
  request.body = std::move(*body);
  request.principal = api::Principal::kCapture;
  request.remoteAddr = "127.0.0.1";
  api::Response response = instance->router.dispatch(std::move(request));
  if (response.status >= 500) {
    std::fprintf(stderr, "fuzz_spec: %d %s\n", response.status, response.json.dump().c_str());
    std::abort();
  }
  if (response.status < 300) ++instance->queued;
  return 0;
}
