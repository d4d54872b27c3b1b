#include "sweeps/skeleton.hpp"

#include <map>

namespace tally::sweeps {

using nlohmann::json;

SweepRun::SweepRun(gpu::Context& context, const SweepOptions& sweepOptions, size_t renders)
    : ctx(context), options(sweepOptions), progress_{0, renders, ""} {}

void SweepRun::next(const std::string& where) {
  if (rendering_) ++progress_.done;
  rendering_ = true;
  progress_.current = where;
  if (options.progress) options.progress(progress_);
}

json SweepRun::finish(std::string_view sweep, const json& spec, json result) {
  if (rendering_) ++progress_.done;
  rendering_ = false;
  progress_.current = "done";
  if (options.progress) options.progress(progress_);
  result["sweep"] = std::string(sweep);
  result["device"] = gpu::describe(ctx);
  result["spec"] = spec;
  result["points"] = std::move(points);
  return result;
}

Result<std::unique_ptr<renderers::Renderer>> setUpRenderer(gpu::Context& ctx, const std::string& name,
                                                           const renderers::GpuScene& scene,
                                                           const renderers::RendererOptions& options) {
  auto made = renderers::makeRenderer(name);
  if (!made) return made.failure();
  auto ok = (*made)->setup(ctx, scene, options);
  if (!ok) return ok.failure();
  return std::move(*made);
}

json plot(const std::string& title, const std::string& x, const std::string& y, bool yLog,
          const std::string& yLabel, json series, json threshold) {
  return {{"title", title},
          {"x", x},
          {"x_log", true},
          {"y", y},
          {"y_log", yLog},
          {"y_label", yLabel},
          {"series", std::move(series)},
          {"threshold", std::move(threshold)}};
}

json smallestFailing(const json& points, const std::string& param, const std::vector<std::string>& groupBy,
                     const std::function<bool(const json&)>& fails, const std::string& reasons) {
  std::map<std::string, json> groups;
  std::vector<std::string> order;
  bool any = false;
  for (const auto& p : points) {
    json key = json::array();
    for (const auto& g : groupBy) key.push_back(p[g]);
    auto [it, inserted] = groups.try_emplace(key.dump());
    json& group = it->second;
    if (inserted) {
      order.push_back(key.dump());
      for (const auto& g : groupBy) group[g] = p[g];
      group[param] = nullptr;
      if (!reasons.empty()) group["metrics"] = nullptr;
    }
    if (!fails(p)) continue;
    any = true;
    if (group[param].is_null() || p[param].get<double>() < group[param].get<double>()) {
      group[param] = p[param];
      if (!reasons.empty()) group["metrics"] = p[reasons];
    }
  }
  if (!any) return nullptr;
  json out = json::array();
  for (const auto& k : order) out.push_back(groups[k]);
  return out;
}

json failsAtByAxis(const std::vector<std::pair<std::string, json>>& axes) {
  json out = json::object();
  bool any = false;
  for (const auto& [axis, failsAt] : axes) {
    any = any || !failsAt.is_null();
    out[axis] = failsAt;
  }
  return any ? out : json(nullptr);
}

}  // namespace tally::sweeps
