// The outline every sweep runs, whatever it varies: its renders one after
// another with progress before each, the scenes they share uploaded once, and
// the result's frame ("sweep", "device", "spec", "points") around the
// sweep's own fields. Beside it, what the sweeps' reports share: the charts
// and the search for where a method starts to fail. A sweep file then holds
// only its own idea: its points, what it measures at each, and its method.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/progress.hpp"
#include "common/result.hpp"
#include "gpu/context.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"
#include "sweeps/options.hpp"

namespace tally::sweeps {

// One run of a sweep: the device, where progress goes and the points
// measured so far.
class SweepRun {
 public:
  // `renders`: how many the sweep runs in all, for the progress.
  SweepRun(gpu::Context& ctx, const SweepOptions& options, size_t renders);

  gpu::Context& ctx;
  const SweepOptions& options;
  nlohmann::json points = nlohmann::json::array();

  // Reports `where` as the render starting now. A render counts as done
  // when the next one starts (or the sweep finishes), so a render that
  // failed is never counted.
  void next(const std::string& where);

  // Uploads `scene` once for the renders that share it and calls
  // `renders(gpuScene)` (a Result<bool>); a failed upload is an error
  // prefixed with `where`. The upload is freed when the renders end,
  // failed or not.
  template <class Renders>
  Result<bool> withScene(const scenes::Scene& scene, const std::string& where, Renders&& renders) {
    renderers::GpuScene gpuScene;
    auto uploaded = gpuScene.upload(ctx, scene);
    if (!uploaded) return makeError(where + ": " + uploaded.error());
    return renders(std::as_const(gpuScene));
  }

  // Reports "done" and returns `result`, the sweep's own fields, with those
  // every sweep result has: "sweep", "device", "spec" and the points.
  nlohmann::json finish(std::string_view sweep, const nlohmann::json& spec, nlohmann::json result);

 private:
  Progress progress_;
  bool rendering_ = false;
};

// Makes the renderer `name` and sets it up on `scene`; the caller renders
// and destroys it.
Result<std::unique_ptr<renderers::Renderer>> setUpRenderer(gpu::Context& ctx, const std::string& name,
                                                           const renderers::GpuScene& scene,
                                                           const renderers::RendererOptions& options);

// One chart of the dashboard (docs/result-schema.md, "Sweep results"): the
// point field `y` against the swept `x` (a log axis: every swept axis spans
// decades), one line per combination of the `series` fields; `threshold`
// is drawn across where it is not null.
nlohmann::json plot(const std::string& title, const std::string& x, const std::string& y, bool yLog,
                    const std::string& yLabel, nlohmann::json series, nlohmann::json threshold);

// Per group of points that agree on `groupBy`, the smallest `param` of a
// point that `fails`: one entry per group, in the order of the groups' first
// points, holding the group's fields and `param` (null where none fails).
// With `reasons`, an entry also holds, as "metrics", that field of the point
// its value came from. Null overall when no point fails.
nlohmann::json smallestFailing(const nlohmann::json& points, const std::string& param,
                               const std::vector<std::string>& groupBy,
                               const std::function<bool(const nlohmann::json&)>& fails,
                               const std::string& reasons = "");

// {axis: fails_at along it, ...}, or null when no axis has a failing point.
nlohmann::json failsAtByAxis(const std::vector<std::pair<std::string, nlohmann::json>>& axes);

}  // namespace tally::sweeps
