#include "api/builtin_routes.hpp"

#include "common/version.hpp"
#include "protocol.hpp"

namespace tally::api {

void addBuiltinRoutes(Router& router, std::vector<std::string> rendererNames, nlohmann::json options,
                      std::vector<std::string> workloadNames) {
  router.get("/api/health", [](const Request&) {
    return Response::ok(
        {{"status", "ok"},
         {"version", std::string(version())},
         {"commit", std::string(gitCommit())},
         {"api_version", protocol::kApiVersion}});
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
