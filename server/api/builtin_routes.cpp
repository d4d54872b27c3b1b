#include "api/builtin_routes.hpp"

#include "common/version.hpp"
#include "protocol.hpp"

namespace tally::api {

void addBuiltinRoutes(Router& router, std::vector<std::string> rendererNames, nlohmann::json options,
                      std::vector<std::string> workloadNames, StoreHealthProbe storeHealth) {
  router.get("/api/health", [storeHealth = std::move(storeHealth)](const Request&) {
    nlohmann::json body = {{"status", "ok"},
                           {"version", std::string(version())},
                           {"commit", std::string(gitCommit())},
                           {"api_version", protocol::kApiVersion}};
    if (!storeHealth) return Response::ok(std::move(body));
    nlohmann::json store = storeHealth();
    const bool healthy = store.value("status", "") == "ok";
    body["store"] = std::move(store);
    if (healthy) return Response::ok(std::move(body));
    body["status"] = "unavailable";
    Response r = Response::ok(std::move(body), 503);
    r.headers.emplace_back("Retry-After", "5");
    return r;
  });
  // Parsed once, so a broken document fails at startup rather than per request.
  auto doc = std::make_shared<const nlohmann::json>(nlohmann::json::parse(openApiDocument()));
  router.get("/api/openapi.json", [doc](const Request&) { return Response::ok(*doc); });
  if (!rendererNames.empty()) {
    router.get("/api/renderers", [names = std::move(rendererNames), options = std::move(options),
                                  workloads = std::move(workloadNames)](const Request&) {
      return Response::ok({{"renderers", names}, {"options", options}, {"workloads", workloads}});
    });
  }
}

}  // namespace tally::api
