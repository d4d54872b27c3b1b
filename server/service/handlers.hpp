// The handlers of the service's routes, by group (capture_routes.cpp,
// run_routes.cpp, report_routes.cpp); service.cpp registers them. Each
// throws on error (errors.hpp). Internal to service/.
#pragma once

#include "api/messages.hpp"
#include "service/service.hpp"

namespace tally::service::detail {

// Captures and hosts.
api::Response postCapture(ServiceContext& ctx, const api::Request& req);
api::Response listCaptures(ServiceContext& ctx, const api::Request& req);
api::Response getCapture(ServiceContext& ctx, const api::Request& req);
api::Response cancelCapture(ServiceContext& ctx, const api::Request& req);
api::Response listHosts(ServiceContext& ctx, const api::Request& req);

// Stored runs, samples, sweeps, devices, scenes, export.
api::Response listRuns(ServiceContext& ctx, const api::Request& req);
api::Response getRun(ServiceContext& ctx, const api::Request& req);
api::Response listSamples(ServiceContext& ctx, const api::Request& req);
api::Response listSweeps(ServiceContext& ctx, const api::Request& req);
api::Response getSweep(ServiceContext& ctx, const api::Request& req);
api::Response getSample(ServiceContext& ctx, const api::Request& req);
api::Response getScreenshot(ServiceContext& ctx, const api::Request& req);
api::Response getSampleTrace(ServiceContext& ctx, const api::Request& req);
api::Response exportRuns(ServiceContext& ctx, const api::Request& req);
api::Response listDevices(ServiceContext& ctx, const api::Request& req);
api::Response listScenes(ServiceContext& ctx, const api::Request& req);

// Reports over stored runs.
api::Response compare(ServiceContext& ctx, const api::Request& req);
api::Response crossover(ServiceContext& ctx, const api::Request& req);
api::Response heatmap(ServiceContext& ctx, const api::Request& req);
api::Response heatmapTopDownPng(ServiceContext& ctx, const api::Request& req);
api::Response accuracy(ServiceContext& ctx, const api::Request& req);
api::Response repeats(ServiceContext& ctx, const api::Request& req);

}  // namespace tally::service::detail
