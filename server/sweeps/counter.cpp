#include "sweeps/counter.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "gpu/context.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/renderer.hpp"
#include "scenes/spec.hpp"
#include "sweeps/fields.hpp"
#include "sweeps/headroom.hpp"
#include "sweeps/skeleton.hpp"

namespace tally::sweeps {

namespace {

using nlohmann::json;
using fields::fieldError;
using fields::show;
constexpr auto kFromTo = json_fields::RangeWords::kFromTo;

constexpr size_t kMaxAxis = 16;

using fields::joined;

// A 16:9 resolution with `pixels` pixels, for reading a load as a screen size.
std::string resolution16x9(double pixels) {
  double h = std::sqrt(pixels * 9.0 / 16.0);
  return std::to_string(int64_t(std::llround(h * 16.0 / 9.0))) + "x" + std::to_string(int64_t(std::llround(h)));
}

}  // namespace

Result<CounterSweepSpec> parseCounterSweepSpec(const json& j, const std::vector<std::string>& knownRenderers) {
  if (auto e =
          fields::specObject(j, {"sweep", "renderers", "layers", "resolutions", "lights", "threshold"})) {
    return *e;
  }
  CounterSweepSpec spec;
  spec.source = j;
  if (j.contains("renderers")) {
    const auto& r = j["renderers"];
    if (!r.is_array() || r.empty() || r.size() > kMaxAxis) {
      return fieldError("renderers", "must be an array of 1 to " + std::to_string(kMaxAxis) + " renderer names");
    }
    spec.renderers.clear();
    for (size_t i = 0; i < r.size(); ++i) {
      std::string f = "renderers[" + std::to_string(i) + "]";
      if (!r[i].is_string() ||
          std::find(knownRenderers.begin(), knownRenderers.end(), r[i].get<std::string>()) == knownRenderers.end()) {
        return fieldError(f, "unknown renderer " + show(r[i]) + " (expected one of " + joined(knownRenderers) + ")");
      }
      if (std::find(spec.renderers.begin(), spec.renderers.end(), r[i].get<std::string>()) != spec.renderers.end()) {
        return fieldError(f, r[i].get<std::string>() + " listed twice");
      }
      spec.renderers.push_back(r[i].get<std::string>());
    }
  }
  if (!j.contains("layers")) return fieldError("layers", "required, e.g. [1, 2, 4, 8]");
  const auto& l = j["layers"];
  if (!l.is_array() || l.empty() || l.size() > kMaxAxis) {
    return fieldError("layers", "must be an array of 1 to " + std::to_string(kMaxAxis) + " layer counts");
  }
  for (size_t i = 0; i < l.size(); ++i) {
    auto v = json_fields::count(l[i], "layers[" + std::to_string(i) + "]", 1, 64, kFromTo);
    if (!v) return v.failure();
    spec.layers.push_back(*v);
  }
  if (!j.contains("resolutions")) return fieldError("resolutions", "required, e.g. [[64, 36], [128, 72]]");
  const auto& rs = j["resolutions"];
  if (!rs.is_array() || rs.empty() || rs.size() > kMaxAxis) {
    return fieldError("resolutions", "must be an array of 1 to " + std::to_string(kMaxAxis) + " [width, height]");
  }
  for (size_t i = 0; i < rs.size(); ++i) {
    auto r = json_fields::resolution(rs[i], json_fields::index("resolutions", i), {1, 1}, kFromTo);
    if (!r) return r.failure();
    spec.resolutions.push_back(*r);
  }
  if (j.contains("lights")) {
    auto v = json_fields::count(j["lights"], "lights", 1, 4096, kFromTo);
    if (!v) return v.failure();
    spec.lights = *v;
  }
  if (j.contains("threshold")) {
    const auto& t = j["threshold"];
    if (!t.is_object() || t.size() != 1 || !t.contains("bits")) {
      return fieldError("threshold", "must be {\"bits\": n}, the counter width whose wrap is the failure, got " + show(t));
    }
    auto v = json_fields::count(t["bits"], "threshold.bits", 8, 64, kFromTo);
    if (!v) return v.failure();
    spec.bits = int(*v);
  }
  if (spec.renderers.size() * spec.layers.size() * spec.resolutions.size() > 512) {
    return fieldError("spec", "more than 512 points (renderers x layers x resolutions)");
  }
  return spec;
}

namespace {

// The point of one renderer at one resolution: the largest slot, the load
// of its pass and what they say about when a slot of `bits` wraps.
json counterPoint(const renderers::FrameResult& frame, const std::string& name, uint32_t layers,
                  const Resolution& res, double wrapAt) {
  CounterHeadroom headroom;
  headroom.note(frame);
  // The slot's own pass sets its load: forward's light loop runs per
  // shaded fragment (grows with overshading), a deferred or visibility
  // shading pass's once per covered pixel (does not).
  const renderers::PassResult* slotPass = nullptr;
  uint64_t heaviest = 0;
  for (const auto& pass : frame.passes) {
    heaviest = std::max(heaviest, pass.fragmentInvocations);
    if (!slotPass || pass.maxSlotCount > slotPass->maxSlotCount) slotPass = &pass;
  }
  const double pixels = double(res.width) * res.height;
  const double load = slotPass ? double(slotPass->fragmentInvocations) : 0.0;
  const double perFragment = load > 0 ? double(headroom.maxSlotCount) / load : 0.0;
  return {{"renderer", name},
          {"layers", layers},
          {"width", res.width},
          {"height", res.height},
          {"pixels", pixels},
          {"overshading", double(heaviest) / pixels},
          {"slot_pass", slotPass ? slotPass->name : ""},
          {"load", load},
          {"load_per_pixel", load / pixels},
          {"max_slot_count", headroom.maxSlotCount},
          {"max_slot", headroom.maxSlot},
          {"counts_per_fragment", perFragment},
          {"error",
           {{"fraction_of_wrap", double(headroom.maxSlotCount) / wrapAt},
            {"wraps", double(headroom.maxSlotCount) >= wrapAt}}},
          {"predicted", {{"wrap_load", perFragment > 0 ? json(wrapAt / perFragment) : json(nullptr)}}}};
}

// Per renderer and overshading (layers): the load at which the worst
// counts per fragment reach 2^bits, the pixels and 16:9 resolution that
// load means at that overshading, and the smallest measured load that did.
json counterFailsAt(const CounterSweepSpec& spec, const json& points, double wrapAt) {
  json failing = json::array();
  bool any = false;
  for (const auto& name : spec.renderers) {
    for (uint32_t layers : spec.layers) {
      double worst = 0, perPixel = 0;
      json measured = nullptr;
      for (const auto& p : points) {
        if (p["renderer"] != name || p["layers"] != layers) continue;
        worst = std::max(worst, p["counts_per_fragment"].get<double>());
        perPixel = std::max(perPixel, p["load_per_pixel"].get<double>());
        if (p["error"]["wraps"].get<bool>() &&
            (measured.is_null() || p["load"].get<double>() < measured.get<double>())) {
          measured = p["load"];
        }
      }
      json entry = {{"renderer", name}, {"layers", layers}, {"load", nullptr}, {"measured_load", measured}};
      if (worst > 0 && perPixel > 0) {
        any = true;
        const double load = wrapAt / worst;
        entry["load"] = load;
        entry["counts_per_fragment"] = worst;
        entry["pixels"] = load / perPixel;
        entry["resolution_16x9"] = resolution16x9(load / perPixel);
      }
      failing.push_back(std::move(entry));
    }
  }
  return any ? json{{"load", failing}} : json(nullptr);
}

}  // namespace

Result<json> runCounterSweep(gpu::Context& ctx, const CounterSweepSpec& spec, const SweepOptions& options) {
  const double wrapAt = std::ldexp(1.0, spec.bits);
  SweepRun run(ctx, options, spec.renderers.size() * spec.layers.size() * spec.resolutions.size());
  for (uint32_t layers : spec.layers) {
    const std::string scenePoint = "layers " + std::to_string(layers);
    auto scene = scenes::makeScene({{"name", "planes"}, {"layers", layers}, {"order", "back-to-front"}});
    if (!scene) return makeError(scenePoint + ": " + scene.error());
    const scenes::Camera camera = scene->fixedCameras.front();
    auto ran = run.withScene(*scene, scenePoint, [&](const renderers::GpuScene& gpuScene) -> Result<bool> {
      for (const auto& res : spec.resolutions) {
        for (const auto& name : spec.renderers) {
          const std::string where =
              name + " " + scenePoint + " at " + std::to_string(res.width) + "x" + std::to_string(res.height);
          run.next(where);
          renderers::RendererOptions ro;
          ro.extent = {res.width, res.height};
          ro.lights = spec.lights;
          auto renderer = setUpRenderer(ctx, name, gpuScene, ro);
          if (!renderer) return makeError(where + ": " + renderer.error());
          const renderers::FrameResult frame = (*renderer)->renderFrame(camera);
          (*renderer)->destroy();
          run.points.push_back(counterPoint(frame, name, layers, res, wrapAt));
        }
      }
      return true;
    });
    if (!ran) return ran.failure();
  }
  const json failsAt = counterFailsAt(spec, run.points, wrapAt);
  return run.finish(
      kCounterSweepName, spec.source,
      {{"parameters", {"renderer", "layers", "pixels"}},
       {"lights", spec.lights},
       {"method",
        {{"scene", "planes, layers back to front (every layer shaded: overshading = layers)"},
         {"load", "fragment invocations of the pass holding the largest slot"},
         {"overshading", "fragment invocations of the heaviest pass / pixels"},
         {"slot", "the largest count one counter slot reached in one frame (counters are zeroed per frame)"},
         {"proof", "tests/integration/overflow_test.cpp: counters preloaded below 2^32 carry exactly"}}},
       {"threshold", {{"bits", spec.bits}}},
       {"fails_at", failsAt},
       {"plots", json::array({plot("Largest counter slot against load", "load", "max_slot_count", true,
                                   "counts in one slot per frame", {"renderer", "layers"}, wrapAt),
                              plot("Counts per fragment (flat: the slot grows with the load)", "load",
                                   "counts_per_fragment", false, "slot counts / fragment",
                                   {"renderer", "layers"}, nullptr),
                              plot("Largest slot against pixels", "pixels", "max_slot_count", true,
                                   "counts in one slot per frame", {"renderer", "layers"}, wrapAt)})}});
}

}  // namespace tally::sweeps
