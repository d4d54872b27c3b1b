// Stored runs, samples, sweeps and devices as they are, the export of their
// counters, and the scenes a capture may name.
#include <algorithm>
#include <system_error>

#include "reports/frame_time.hpp"
#include "service/admission.hpp"
#include "service/handlers.hpp"
#include "service/routes.hpp"
#include "service/sites_routes.hpp"
#include "service/trace.hpp"

namespace tally::service::detail {
namespace fs = std::filesystem;
using api::Request;
using api::Response;
using nlohmann::json;

Response listRuns(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"renderer", "variant", "scene", "width", "height", "device", "capture", "host", "label", "since", "until", "limit",
                  "cursor"});
  auto filter = queryFilter(req);
  auto& store = reader(ctx);
  auto page = check(store.runs().list(filter, queryPage(req)));
  // The frame times stored at ingest (0013); those of runs stored before, in
  // one statement: the listing is one statement, or two with such runs.
  auto frameTimes = check(reports::frameTimesOf(store, page.runs));
  // Written as text, without a json value per run (json_rows.hpp).
  return Response::raw(runPageText(page, frameTimes), "application/json");
}

Response getRun(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto found = check(reader(ctx).runs().detail(id));  // one transaction
  if (!found) missing("no run " + std::to_string(id));
  auto frameTime = check(reports::frameTimeOf(reader(ctx), found->run.row));
  // Written as text, without a json value (json_rows.hpp).
  return Response::raw(runDetailText(*found, &frameTime), "application/json");
}

Response listSweeps(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"name", "device", "capture", "since", "until", "limit", "cursor"});
  // The same device, capture and time filters as /api/runs.
  store::RunFilter common = queryFilter(req);
  store::SweepFilter filter;
  filter.name = queryString(req, "name");
  filter.deviceId = common.deviceId;
  filter.deviceName = common.deviceName;
  filter.jobId = common.jobId;
  filter.createdSince = common.createdSince;
  filter.createdUntil = common.createdUntil;
  auto page = check(reader(ctx).runs().sweeps(filter, queryPage(req)));
  json sweeps = json::array();
  for (const auto& s : page.sweeps) sweeps.push_back(sweepRowJson(s));
  return Response::ok(
      {{"sweeps", sweeps}, {"next_cursor", page.nextCursor.empty() ? json(nullptr) : json(page.nextCursor)}});
}

Response getSweep(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto sweep = check(reader(ctx).runs().sweep(id));
  if (!sweep) missing("no sweep " + std::to_string(id));
  json j = sweepRowJson(sweep->row);
  j["result"] = sweep->result;
  return Response::ok(j);
}

Response listSamples(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto& store = reader(ctx);
  if (!check(store.runs().get(id))) missing("no run " + std::to_string(id));
  json samples = json::array();
  for (const auto& s : check(store.runs().samples(id))) samples.push_back(sampleRowJson(s));
  return Response::ok({{"samples", samples}});
}

Response getSample(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto sample = check(reader(ctx).runs().sample(id));
  if (!sample) missing("no sample " + std::to_string(id));
  json j = sampleRowJson(sample->row);
  // Per-frame times (0008): null where not stored.
  auto frameTimes = [](const std::vector<double>& ms) { return ms.empty() ? json(nullptr) : json(ms); };
  j["frame_ms_frames"] = frameTimes(sample->row.frameMsFrames);
  json passes = json::array();
  for (const auto& p : sample->passes) {
    json pass = passJson(p);
    pass["gpu_ms_frames"] = frameTimes(p.gpuMsFrames);
    passes.push_back(std::move(pass));
  }
  j["passes"] = passes;
  return Response::ok(j);
}

// The sample as a Chrome trace-event JSON trace (service/trace.hpp).
Response getSampleTrace(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto& store = reader(ctx);
  auto sample = check(store.runs().sample(id));
  if (!sample) missing("no sample " + std::to_string(id));
  auto run = check(store.runs().get(sample->row.runId));
  if (!run) missing("no run for sample " + std::to_string(id));
  constexpr int kTopLines = 5;  // per pass: enough to name the hot spots, few enough to read in the slice's args
  return Response::ok(sampleTrace(run->row, *sample, topLinesPerPass(store, id, kTopLines)));
}

Response getScreenshot(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  int64_t id = pathId(req);
  auto png = check(reader(ctx).runs().screenshot(id));
  if (!png) missing("no screenshot for sample " + std::to_string(id));
  return Response::raw(std::string(png->begin(), png->end()), "image/png");
}

Response exportRuns(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"format", "renderer", "variant", "scene", "width", "height", "device", "capture", "since", "until", "runs"});
  std::string format = queryString(req, "format", 8).value_or("json");
  if (format != "csv" && format != "json") invalid("format", "must be csv or json");
  store::RunFilter filter = queryFilter(req);
  if (req.queryValue("runs")) filter.runIds = runIdList(req, 1, 1000);  // the store's limit
  auto rows = check(reader(ctx).runs().exportRows(filter));
  if (format == "json") {
    json out = json::array();
    for (const auto& r : rows) {
      out.push_back({{"run", r.runId},
                     {"renderer", r.renderer},
                     {"scene", r.scene},
                     {"width", r.width},
                     {"height", r.height},
                     {"device", r.device},
                     {"pass", r.pass},
                     {"resource", r.resource},
                     {"access", r.access},
                     {"count", r.count},
                     {"bytes", r.bytes},
                     {"footprint_bytes", opt(r.footprintBytes)},
                     {"reuse", reuseJson(r.footprintRequestedBytes, r.footprintBytes)}});
    }
    return Response::ok({{"rows", out}});
  }
  // bytes: requested. Where any row has a footprint, two more columns follow,
  // footprint_bytes and reuse (empty where not measured); an export without
  // footprint keeps the columns it always had.
  bool footprint = std::any_of(rows.begin(), rows.end(), [](const store::ExportRow& r) { return r.footprintBytes.has_value(); });
  std::string csv = std::string("run,renderer,scene,width,height,device,pass,resource,access,count,bytes") +
                    (footprint ? ",footprint_bytes,reuse" : "") + "\r\n";
  auto num = [](double v) {
    json j = v;  // shortest round-trip text
    return j.dump();
  };
  auto optNum = [](const json& v) { return v.is_null() ? std::string() : v.dump(); };
  for (const auto& r : rows) {
    csv += std::to_string(r.runId) + "," + csvCell(r.renderer) + "," + csvCell(r.scene) + "," +
           std::to_string(r.width) + "," + std::to_string(r.height) + "," + csvCell(r.device) + "," +
           csvCell(r.pass) + "," + csvCell(r.resource) + "," + csvCell(r.access) + "," + num(r.count) + "," +
           num(r.bytes) +
           (footprint ? "," + optNum(opt(r.footprintBytes)) + "," +
                            optNum(reuseJson(r.footprintRequestedBytes, r.footprintBytes))
                      : std::string()) +
           "\r\n";
  }
  Response resp = Response::raw(std::move(csv), "text/csv; charset=utf-8");
  resp.headers.emplace_back("Content-Disposition", "attachment; filename=\"tally-export.csv\"");
  return resp;
}

Response listDevices(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  json devices = json::array();
  for (const auto& d : check(reader(ctx).runs().devices())) devices.push_back(deviceJson(d));
  return Response::ok({{"devices", devices}});
}

Response listScenes(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {});
  json procedural = json::array({
      {{"name", "atrium"}, {"parameters", json::object()}},
      {{"name", "planes"},
       {"parameters",
        {{"layers", {{"type", "integer"}, {"default", 8}, {"min", 1}, {"max", 1024}}},
         {"order", {{"type", "string"}, {"default", "back-to-front"}, {"values", {"back-to-front", "front-to-back"}}}},
         {"coverage", {{"type", "number"}, {"default", 1.0}, {"min_exclusive", 0.0}, {"max", 1.0}}}}}},
      {{"name", "sky"}, {"parameters", {{"coverage", {{"type", "number"}, {"default", 0.5}, {"min", 0.0}, {"max", 1.0}}}}}},
  });
  constexpr size_t kMaxFiles = 1000;  // per folder: a listing, not a crawl
  json folders = json::array();
  for (const auto& folder : ctx.options.sceneFolders) {
    std::error_code ec;
    fs::path root = fs::canonical(folder, ec);
    json files = json::array();
    if (!ec) {
      fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec), end;
      for (; !ec && it != end && files.size() < kMaxFiles; it.increment(ec)) {
        if (it.depth() > 8) {
          it.disable_recursion_pending();
          continue;
        }
        auto ext = it->path().extension().string();
        if (ext != ".gltf" && ext != ".glb") continue;
        // Only files inside the folder, listed by their own name: a link is
        // listed when its target is a file inside too (resolveGltf accepts
        // it), and never by where it points.
        std::error_code fileError;
        fs::path real = fs::canonical(it->path(), fileError);
        if (fileError || !under(real, root) || !fs::is_regular_file(real, fileError)) continue;
        files.push_back(it->path().lexically_relative(root).string());
      }
    }
    folders.push_back({{"folder", folder.string()}, {"files", files}});
  }
  return Response::ok({{"procedural", procedural}, {"gltf", folders}});
}

}  // namespace tally::service::detail
