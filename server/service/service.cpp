// The service's routes, registered in one place; their handlers lie in a
// file per group (handlers.hpp) and every one answers through wrap().
#include "service/service.hpp"

#include "service/alerts.hpp"
#include "service/errors.hpp"
#include "service/handlers.hpp"
#include "service/read_stores.hpp"
#include "service/sites_routes.hpp"

namespace tally::service {
using namespace detail;

std::string csvCell(const std::string& value) {
  std::string v = value;
  // A leading = + - @ would run as a formula in a spreadsheet.
  if (!v.empty() && (v[0] == '=' || v[0] == '+' || v[0] == '-' || v[0] == '@')) v = "'" + v;
  if (v.find_first_of(",\"\r\n") == std::string::npos) return v;
  std::string out = "\"";
  for (char c : v) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

void addServiceRoutes(api::Router& router, ServiceContext& ctx) {
  if (!ctx.readers) ctx.readers = std::make_shared<ReadStores>(ctx.dbPath);
  auto route = [&ctx](RouteHandler fn) { return routed(ctx, fn); };
  router.post("/api/captures", route(postCapture));
  router.get("/api/captures", route(listCaptures));
  router.get("/api/captures/{id}", route(getCapture));
  router.del("/api/captures/{id}", route(cancelCapture));
  router.get("/api/runs", route(listRuns));
  router.get("/api/runs/{id}", route(getRun));
  router.get("/api/runs/{id}/samples", route(listSamples));
  router.get("/api/sweeps", route(listSweeps));
  router.get("/api/sweeps/{id}", route(getSweep));
  router.get("/api/samples/{id}", route(getSample));
  router.get("/api/samples/{id}/screenshot.png", route(getScreenshot));
  router.get("/api/samples/{id}/trace", route(getSampleTrace));
  router.get("/api/compare", route(compare));
  router.get("/api/crossover", route(crossover));
  router.get("/api/heatmap", route(heatmap));
  router.get("/api/heatmap/{id}/topdown.png", route(heatmapTopDownPng));
  router.get("/api/accuracy", route(accuracy));
  router.get("/api/repeats", route(repeats));
  router.get("/api/export", route(exportRuns));
  router.get("/api/devices", route(listDevices));
  router.get("/api/hosts", route(listHosts));
  router.get("/api/scenes", route(listScenes));
  addAlertRoutes(router, ctx);
  addSiteRoutes(router, ctx);
}

}  // namespace tally::service
