// What is computed from stored runs (reports/), answered: comparison with
// significance, crossover, heatmaps, accuracy and repeats.
#include "reports/accuracy.hpp"
#include "reports/crossover.hpp"
#include "reports/frame_time.hpp"
#include "reports/heatmap.hpp"
#include "reports/repeats.hpp"
#include "reports/run_significance.hpp"
#include "common/resolution.hpp"
#include "service/handlers.hpp"
#include "service/routes.hpp"

namespace tally::service::detail {
using api::Request;
using api::Response;
using nlohmann::json;

namespace {

// A heatmap's failure thrown as the service's errors: the store's as a
// store error, a missing plan by its message alone (what is missing is the
// plan, not a field), the rest (400, or 404 for the map) naming their field.
void throwFailure(const reports::HeatmapAnswer& answer, bool plan) {
  if (!answer.failure) return;
  using Kind = reports::HeatmapFailure::Kind;
  const reports::HeatmapFailure& f = *answer.failure;
  if (f.kind == Kind::kStore) check(Result<bool>(makeError(f.message)));
  const bool absent = f.kind == Kind::kMissing;
  if (absent && plan) missing(f.message);
  throw RequestError(absent ? 404 : 400, absent ? api::code::kNotFound : api::code::kInvalidField,
                     f.field + ": " + f.message, f.field);
}

}  // namespace

// Non-exact runs against their exact reference (reports/accuracy.hpp).
Response accuracy(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"renderer", "variant", "scene", "width", "height", "device", "capture", "since", "until"});
  return Response::ok(check(reports::accuracyRows(reader(ctx), queryFilter(req))));
}

// Groups of identical-configuration runs and their agreement (reports/repeats.hpp).
Response repeats(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"renderer", "variant", "scene", "width", "height", "device", "capture", "since", "until"});
  return Response::ok(check(reports::repeatGroups(reader(ctx), queryFilter(req))));
}

Response compare(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"runs", "confidence", "threshold", "across_capture", "strata"});
  std::vector<int64_t> ids = runIdList(req, 2, 4);
  reports::SignificanceOptions options;
  options.compare.confidence = queryDouble(req, "confidence", 0.5, 1, false, true).value_or(0.95);
  options.compare.practicalThreshold = queryDouble(req, "threshold", 0, 10, false, false).value_or(0);
  options.acrossCapture = queryBool(req, "across_capture").value_or(true);
  std::string strata = queryString(req, "strata", 16).value_or("cameras");
  if (strata != "cameras" && strata != "none") invalid("strata", "must be cameras or none");
  options.camerasAsStrata = strata == "cameras";
  auto& store = reader(ctx);
  // Each run and its samples read once, for every comparison it is in.
  std::vector<reports::StoredRun> runs;
  for (int64_t id : ids) {
    auto run = check(reports::loadStoredRun(store, id));
    if (!run) missing("no run " + std::to_string(id));
    runs.push_back(std::move(*run));
  }
  store::Comparison comparison = check(store.runs().compare(ids));
  json out = comparisonJson(comparison);
  // The runs' frame times as medians (reports/frame_time.hpp), beside the
  // store's frame_ms (the mean of the samples' medians), against the first.
  json medians = json::array();
  std::optional<double> first;
  auto frameTimes = check(reports::frameTimesOf(store, comparison.runs));
  for (size_t i = 0; i < ids.size(); ++i) {
    const reports::RunFrameTime& t = frameTimes[ids[i]];
    out["runs"][i] = runRowJson(comparison.runs[i], &t);
    if (i == 0) first = t.median;
    bool against = first && t.median && *first != 0;
    medians.push_back({{"value", t.median ? json(*t.median) : json(nullptr)},
                       {"delta", against ? json(*t.median - *first) : json(nullptr)},
                       {"ratio", against ? json(*t.median / *first) : json(nullptr)}});
  }
  out["frame_ms_median"] = std::move(medians);
  // Each later run against the first: times tested, counts exact.
  json significance = json::array();
  for (size_t i = 1; i < runs.size(); ++i) {
    significance.push_back(reports::toJson(check(reports::runSignificance(store, runs[0], runs[i], options))));
  }
  out["significance"] = std::move(significance);
  out["confidence"] = options.compare.confidence;
  out["threshold"] = options.compare.practicalThreshold;
  return Response::ok(std::move(out));
}

// Each variant's metric fitted against the pixel count over one capture's
// runs, and where pairs of variants cross (reports/crossover.hpp).
Response crossover(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"capture", "metric", "scene", "device"});
  if (!req.queryValue("capture")) invalid("capture", "required: the capture whose runs are fitted");
  std::string metric = queryString(req, "metric", 16).value_or("bytes");
  if (!reports::isCrossoverMetric(metric)) invalid("metric", "must be bytes or frame_ms");
  store::RunFilter filter = queryFilter(req);
  auto& store = reader(ctx);
  if (!check(store.jobs().get(*filter.jobId))) missing("no capture " + std::to_string(*filter.jobId));
  return Response::ok(check(reports::crossoverModels(store, filter, metric)));
}

// A heatmap capture's map: one variant's metric per cell, or two variants'
// and their ratio with its significance (reports/heatmap.hpp).
Response heatmap(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"capture", "renderer", "versus", "metric", "yaw", "scene", "width", "height", "counting"});
  if (!req.queryValue("capture")) invalid("capture", "required: the heatmap capture");
  reports::HeatmapQuery q;
  q.capture = *queryInt(req, "capture", 1, INT64_MAX);
  auto renderer = queryString(req, "renderer");
  if (!renderer) invalid("renderer", "required: the variant measured (its label, e.g. deferred)");
  q.renderer = *renderer;
  q.versus = queryString(req, "versus");
  q.metric = queryString(req, "metric", 16).value_or("frame_ms");
  if (q.metric != "frame_ms" && q.metric != "bytes") invalid("metric", "must be frame_ms or bytes");
  q.yaw = queryString(req, "yaw", 16).value_or("mean");
  q.scene = queryString(req, "scene");
  q.counting = queryString(req, "counting", 64);
  if (auto w = queryInt(req, "width", 1, kMaxDimension)) q.width = static_cast<int>(*w);
  if (auto h = queryInt(req, "height", 1, kMaxDimension)) q.height = static_cast<int>(*h);
  auto& store = reader(ctx);
  if (!check(store.jobs().get(q.capture))) missing("no capture " + std::to_string(q.capture));
  reports::HeatmapAnswer answer = reports::heatmapMap(store, q);
  throwFailure(answer, false);
  return Response::ok(std::move(answer.body));
}

// The top-down plan of a floor heatmap (PNG).
Response heatmapTopDownPng(ServiceContext& ctx, const Request& req) {
  allowOnly(req, {"scene"});
  int64_t id = pathId(req);
  auto scene = queryString(req, "scene");
  auto& store = reader(ctx);
  if (!check(store.jobs().get(id))) missing("no capture " + std::to_string(id));
  reports::HeatmapAnswer answer = reports::heatmapTopDown(store, id, scene, ctx.options.sceneFolders);
  throwFailure(answer, true);
  return Response::raw(std::string(answer.png.begin(), answer.png.end()), "image/png");
}

}  // namespace tally::service::detail
