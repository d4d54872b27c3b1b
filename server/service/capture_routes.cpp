// Capture jobs (POST, GET and DELETE /api/captures) and the fleet's hosts.
#include <optional>

#include "service/admission.hpp"
#include "service/handlers.hpp"
#include "service/routes.hpp"
#include "service/store_health.hpp"

namespace tally::service::detail {
using api::Request;
using api::Response;
using nlohmann::json;

Response postCapture(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  json spec = validateSpec(ctx, req.body, req.principal);
  std::optional<std::string> key;
  if (!req.idempotencyKey.empty()) key = req.idempotencyKey;
  requireWritable(ctx);
  auto created = check(ctx.writer->jobs().create(spec, key, ctx.options.maxAttempts, queueLimits(ctx, req)));
  if (ctx.health) ctx.health->noteWriteOk();
  if (!created.refused.empty()) refuseQueued(ctx, created);
  if (created.conflict) {
    throw RequestError(409, api::code::kConflict,
                       "Idempotency-Key was used before with a different spec (capture " +
                           std::to_string(created.job.id) + ")",
                       "Idempotency-Key");
  }
  if (created.created && ctx.onJobQueued) ctx.onJobQueued();
  Response r = Response::ok({{"id", created.job.id}, {"status", store::toString(created.job.status)}}, 202);
  r.headers.emplace_back("Location", "/api/captures/" + std::to_string(created.job.id));
  return r;
}

Response listCaptures(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"status", "limit", "cursor"});
  std::optional<store::JobStatus> status;
  if (auto s = queryString(req, "status", 32)) {
    status = store::parseJobStatus(*s);
    if (!status) invalid("status", "must be queued, running, done, failed or cancelled");
  }
  auto& store = reader(ctx);
  auto page = check(store.jobs().list(status, queryPage(req)));
  std::optional<std::vector<store::Host>> hosts;
  json jobs = json::array();
  for (const auto& j : page.jobs) {
    json out = jobJson(j);
    if (j.status == store::JobStatus::Queued) {
      if (!hosts) hosts = check(store.hosts().list(ctx.options.staleAfterMs));
      out["waiting"] = waitingReason(j, *hosts, ctx.options.staleAfterMs);
    }
    jobs.push_back(std::move(out));
  }
  return Response::ok({{"captures", jobs}, {"next_cursor", page.nextCursor.empty() ? json(nullptr) : json(page.nextCursor)}});
}

Response getCapture(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto& store = reader(ctx);
  auto job = check(store.jobs().get(id));
  if (!job) missing("no capture " + std::to_string(id));
  json j = jobJson(*job);
  j["sweeps"] = check(store.runs().jobSweepIds(id));  // a finished sweep job's sweep
  if (job->status == store::JobStatus::Queued) {
    j["waiting"] =
        waitingReason(*job, check(store.hosts().list(ctx.options.staleAfterMs)), ctx.options.staleAfterMs);
  }
  return Response::ok(j);
}

Response cancelCapture(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto before = check(ctx.writer->jobs().get(id));
  if (!before) missing("no capture " + std::to_string(id));
  const bool finished = store::isFinal(before->status);
  if (!finished) requireWritable(ctx);
  auto job = finished ? before : check(ctx.writer->jobs().cancel(id));
  if (!finished && ctx.health) ctx.health->noteWriteOk();
  if (!job) missing("no capture " + std::to_string(id));
  // Finished before (a second cancel included) or meanwhile: nothing to cancel.
  if (finished || job->status != store::JobStatus::Cancelled) {
    throw RequestError(409, api::code::kConflict,
                       "capture " + std::to_string(id) + " has already finished (" + store::toString(job->status) + ")");
  }
  // A running job is reported by the worker when it stops the child.
  if (before->status == store::JobStatus::Queued && ctx.onQueuedJobCancelled) ctx.onQueuedJobCancelled(id);
  return Response::ok(jobJson(*job));
}

Response listHosts(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  json hosts = json::array();
  for (const auto& h : check(reader(ctx).hosts().list(ctx.options.staleAfterMs)))
    hosts.push_back(hostJson(h));
  return Response::ok({{"hosts", hosts}, {"stale_after_s", static_cast<double>(ctx.options.staleAfterMs) / 1000.0}});
}

}  // namespace tally::service::detail
