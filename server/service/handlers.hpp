// The handlers of the service's routes, by group (capture_routes.cpp,
// run_routes.cpp, report_routes.cpp); service.cpp registers them. Each
// throws on error (errors.hpp). Internal to service/.
#pragma once

#include "api/messages.hpp"
#include "service/service.hpp"

namespace tally::service::detail {

using Req = api::Request;
using Resp = api::Response;

// Captures and hosts.
Resp postCapture(ServiceContext& ctx, const Req& req);
Resp listCaptures(ServiceContext& ctx, const Req& req);
Resp getCapture(ServiceContext& ctx, const Req& req);
Resp cancelCapture(ServiceContext& ctx, const Req& req);
Resp listHosts(ServiceContext& ctx, const Req& req);

// Stored runs, samples, sweeps, devices, scenes, export.
Resp listRuns(ServiceContext& ctx, const Req& req);
Resp getRun(ServiceContext& ctx, const Req& req);
Resp listSamples(ServiceContext& ctx, const Req& req);
Resp listSweeps(ServiceContext& ctx, const Req& req);
Resp getSweep(ServiceContext& ctx, const Req& req);
Resp getSample(ServiceContext& ctx, const Req& req);
Resp getScreenshot(ServiceContext& ctx, const Req& req);
Resp getSampleTrace(ServiceContext& ctx, const Req& req);
Resp exportRuns(ServiceContext& ctx, const Req& req);
Resp listDevices(ServiceContext& ctx, const Req& req);
Resp listScenes(ServiceContext& ctx, const Req& req);

// Reports over stored runs.
Resp compare(ServiceContext& ctx, const Req& req);
Resp crossover(ServiceContext& ctx, const Req& req);
Resp heatmap(ServiceContext& ctx, const Req& req);
Resp heatmapTopDownPng(ServiceContext& ctx, const Req& req);
Resp accuracy(ServiceContext& ctx, const Req& req);
Resp repeats(ServiceContext& ctx, const Req& req);

}  // namespace tally::service::detail
