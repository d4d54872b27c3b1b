#include "sweeps/depth.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "renderers/gpu_scene.hpp"
#include "renderers/projection.hpp"
#include "renderers/renderer.hpp"
#include "scenes/mesh_builder.hpp"
#include "scenes/textures.hpp"
#include "sweeps/fields.hpp"
#include "sweeps/skeleton.hpp"

namespace tally::sweeps {
namespace {

using nlohmann::json;

// The plane is tilted so that view depth runs from d / (1 + kTilt) to
// d / (1 - kTilt) corner to corner. A plane facing the camera would give every
// pixel the same depth value, so one rounding would decide the whole point;
// the tilt samples thousands of them.
constexpr double kTilt = 0.1;

using fields::fieldError;
using fields::num;
using fields::show;

// An axis of distinct positive finite numbers, each > `above`.
Result<std::vector<double>> positiveList(const json& j, const std::string& field, double above) {
  return fields::distinctList<double>(
      j, field, kMaxSweepAxis, "numbers", [&](const json& v, const std::string& f) -> Result<double> {
        if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() <= above ||
            v.get<double>() > double(std::numeric_limits<float>::max())) {
          return fieldError(f, "must be a finite number greater than " + num(above) + ", got " + show(v));
        }
        return v.get<double>();
      });
}

}  // namespace

std::vector<std::string> depthReconstructingRenderers() { return {"deferred"}; }

std::vector<DepthSweepSpec::Range> DepthSweepSpec::ranges() const {
  std::vector<Range> out;
  for (double n : near) {
    for (double x : byRatio() ? farOverNear : far) out.push_back({n, byRatio() ? n * x : x});
  }
  return out;
}

Result<DepthSweepSpec> parseDepthSweepSpec(const json& j, const std::vector<std::string>& knownRenderers) {
  if (auto e = fields::specObject(j, {"sweep", "renderer", "near", "far", "far_over_near", "distances",
                                      "resolution", "fov_deg", "threshold"}))
    return *e;
  DepthSweepSpec spec;
  spec.source = j;

  if (j.contains("renderer")) {
    auto name = fields::rendererName(j["renderer"], "renderer", depthReconstructingRenderers(),
                                     knownRenderers, "does not reconstruct position from depth");
    if (!name) return name.failure();
    spec.renderer = *name;
  }

  if (!j.contains("near")) return fieldError("near", "required, e.g. [0.1]");
  auto near = positiveList(j["near"], "near", 0.0);
  if (!near) return near.failure();
  spec.near = *near;

  bool hasFar = j.contains("far"), hasRatio = j.contains("far_over_near");
  if (hasFar == hasRatio) return fieldError("far", "give exactly one of far and far_over_near");
  if (hasFar) {
    auto far = positiveList(j["far"], "far", 0.0);
    if (!far) return far.failure();
    spec.far = *far;
  } else {
    auto ratio = positiveList(j["far_over_near"], "far_over_near", 1.0);
    if (!ratio) return ratio.failure();
    spec.farOverNear = *ratio;
  }

  if (!j.contains("distances")) return fieldError("distances", "required, e.g. [1, 10, 100]");
  auto distances = positiveList(j["distances"], "distances", 0.0);
  if (!distances) return distances.failure();
  spec.distances = *distances;

  if (j.contains("resolution")) {
    auto r = fields::resolution(j["resolution"]);
    if (!r) return r.failure();
    spec.resolution = *r;
  }

  if (j.contains("fov_deg")) {
    const auto& f = j["fov_deg"];
    if (!f.is_number() || f.get<double>() < 1.0 || f.get<double>() > 170.0) {
      return fieldError("fov_deg", "must be a number between 1 and 170, got " + show(f));
    }
    spec.fovDeg = f.get<double>();
  }

  if (!j.contains("threshold")) return fieldError("threshold", "required, e.g. {\"relative\": 1e-3}");
  const auto& t = j["threshold"];
  if (!t.is_object() || t.size() != 1 || !(t.contains("relative") || t.contains("absolute"))) {
    return fieldError("threshold", "must be {\"relative\": x} (error / distance) or {\"absolute\": metres}, got " +
                                       show(t));
  }
  spec.relativeThreshold = t.contains("relative");
  std::string tf = spec.relativeThreshold ? "threshold.relative" : "threshold.absolute";
  const auto& tv = t.begin().value();
  if (!tv.is_number() || !std::isfinite(tv.get<double>()) || tv.get<double>() <= 0 ||
      (spec.relativeThreshold && tv.get<double>() >= 1)) {
    return fieldError(tf, std::string("must be a number in (0, ") + (spec.relativeThreshold ? "1)" : "inf)") +
                              ", got " + show(tv));
  }
  spec.threshold = tv.get<double>();

  // Every pixel's plane point must lie strictly between the near and far planes.
  auto ranges = spec.ranges();
  if (ranges.size() * spec.distances.size() > kMaxSweepPoints) {
    return fieldError("spec", "the sweep has " + std::to_string(ranges.size() * spec.distances.size()) +
                                  " points, more than the limit of " + std::to_string(kMaxSweepPoints));
  }
  for (const auto& range : ranges) {
    if (!(float(range.far) > float(range.near))) {
      return fieldError("far", "far " + num(range.far) + " is not beyond near " + num(range.near));
    }
    for (size_t i = 0; i < spec.distances.size(); ++i) {
      double d = spec.distances[i];
      if (!(d / (1 + kTilt) > range.near && d / (1 - kTilt) < range.far)) {
        return fieldError("distances[" + std::to_string(i) + "]",
                          "the plane at " + num(d) + " spans view depths " + num(d / (1 + kTilt)) + " to " +
                              num(d / (1 - kTilt)) + ", not all between near " + num(range.near) + " and far " +
                              num(range.far));
      }
    }
  }
  return spec;
}

double depthOf(double t, double zNear, double zFar) { return zFar * (t - zNear) / ((zFar - zNear) * t); }

double depthStepDistance(double t, double rayLength, double zNear, double zFar) {
  double d = depthOf(t, zNear, zFar);
  // float32: 24 significant bits, so values in [2^e, 2^(e+1)) lie 2^(e-23) apart.
  double ulp = std::ldexp(1.0, std::ilogb(d) - 23);
  double dtdD = (zFar - zNear) * t * t / (zFar * zNear);
  return ulp * dtdD * rayLength / t;
}

namespace {

// The plane z = -d + a x + b y (view = world: the camera sits at the origin
// looking down -Z), wide enough to fill the view with a margin; material as
// the procedural scenes use (the lighting pass needs one).
struct Plane {
  double d = 0, a = 0, b = 0;
};

scenes::Scene planeScene(const Plane& plane, double tanHalf, double aspect) {
  scenes::Scene scene;
  scene.name = "depth-plane";
  uint32_t material = scenes::addProceduralMaterial(scene, scenes::ProceduralMaterial::Plaster, 4);
  // At the margin the plane lies nearer than d / (1 - kTilt) * 1.5.
  double s = plane.d / (1.0 - 2 * kTilt) * tanHalf * 1.5, w = s * aspect;
  const glm::vec3 facing(-float(plane.a), -float(plane.b), 1.0f);
  scenes::MeshBuilder b;
  auto v = [&](double x, double y) {
    glm::vec3 p(float(x), float(y), float(-plane.d + plane.a * x + plane.b * y));
    return b.vertex(p, glm::normalize(facing), {0, 0});
  };
  uint32_t i0 = v(-w, -s), i1 = v(w, -s), i2 = v(w, s), i3 = v(-w, s);
  b.triangle(i0, i1, i2, facing);
  b.triangle(i0, i2, i3, facing);
  scene.meshes.push_back(b.finish("plane", material));
  scenes::updateBounds(scene);
  return scene;
}

struct ErrorStats {
  double maxAbs = 0, meanAbs = 0, maxRelative = 0, meanRelative = 0;
  size_t pixels = 0;
  json toJson() const {
    return {{"max_abs", maxAbs}, {"mean_abs", meanAbs}, {"max_relative", maxRelative},
            {"mean_relative", meanRelative}, {"pixels", pixels}};
  }
};

struct Accumulator {
  ErrorStats s;
  double sumAbs = 0, sumRelative = 0;
  void add(double abs, double relative) {
    s.maxAbs = std::max(s.maxAbs, abs);
    s.maxRelative = std::max(s.maxRelative, relative);
    sumAbs += abs;
    sumRelative += relative;
    ++s.pixels;
  }
  ErrorStats done() {
    if (s.pixels) {
      s.meanAbs = sumAbs / double(s.pixels);
      s.meanRelative = sumRelative / double(s.pixels);
    }
    return s;
  }
};

// Per group of points that differ only in `param`, the smallest value of it
// whose `metric` (error or predicted) reaches the threshold; null where none
// does. Null overall when no point fails.
json failsAt(const json& points, const std::string& param, const std::vector<std::string>& groupBy,
             const std::string& metric, const DepthSweepSpec& spec) {
  const std::string key = spec.relativeThreshold ? "max_relative" : "max_abs";
  return smallestFailing(points, param, groupBy,
                         [&](const json& p) { return p[metric][key].get<double>() >= spec.threshold; });
}

// The camera of every point: at the origin, looking down -Z, +Y up (view = identity).
scenes::Camera headOn(double fovDeg) {
  scenes::Camera camera;
  camera.eye = glm::vec3(0.0f);
  camera.target = glm::vec3(0.0f, 0.0f, -1.0f);
  camera.fovDeg = float(fovDeg);
  camera.label = "head-on";
  return camera;
}

// What one point compares: the plane, the camera and the depth range it was drawn with.
struct DepthPoint {
  const Plane& plane;
  const scenes::Camera& camera;
  VkExtent2D extent;
  renderers::DepthRange depthRange;
};

// Every pixel reconstructed from `depth` against the true plane point; the
// measured error and the float32 depth step there. Errs where a pixel kept
// the cleared depth.
Result<std::pair<ErrorStats, ErrorStats>> reconstructionError(const DepthPoint& at,
                                                              const std::vector<float>& depth) {
  const uint32_t width = at.extent.width, height = at.extent.height;
  const glm::dmat4 worldFromView = glm::inverse(glm::dmat4(scenes::viewMatrix(at.camera)));
  const double tanHalf = std::tan(glm::radians(double(at.camera.fovDeg)) / 2.0);
  const double aspect = double(float(width) / float(height));
  // The uniform the renderer uploaded, and lighting.frag's worldFromDepth
  // (common.h) in float, as the shader computes it.
  const shaders::Camera c = renderers::cameraUniform(at.camera, at.extent, at.depthRange);
  const double n = double(at.depthRange.zNear), f = double(at.depthRange.zFar);
  Accumulator measured, predicted;
  size_t sky = 0;
  for (uint32_t y = 0; y < height; ++y) {
    for (uint32_t x = 0; x < width; ++x) {
      float depthValue = depth[size_t(y) * width + x];
      if (depthValue >= 1.0f) {
        ++sky;
        continue;
      }
      glm::vec2 fragCoord(float(x) + 0.5f, float(y) + 0.5f);
      glm::vec4 h = c.invViewProj * glm::vec4(fragCoord * glm::vec2(c.viewport.z, c.viewport.w) * 2.0f - 1.0f,
                                              depthValue, 1.0f);
      glm::dvec3 reconstructed = glm::dvec3(glm::vec3(h) / h.w);
      // The true point: the pixel centre's ray (view space; NDC y =
      // -y_view / (t tan), the projection flips y) meets the plane at
      // view depth t = d / (1 + a dx + b dy).
      double ndcX = (double(x) + 0.5) / width * 2.0 - 1.0, ndcY = (double(y) + 0.5) / height * 2.0 - 1.0;
      glm::dvec3 dir(ndcX * tanHalf * aspect, -ndcY * tanHalf, -1.0);
      double t = at.plane.d / (1.0 + at.plane.a * dir.x + at.plane.b * dir.y);
      glm::dvec3 view = dir * t;
      glm::dvec3 truth = glm::dvec3(worldFromView * glm::dvec4(view, 1.0));
      double rayLength = glm::length(view);
      double error = glm::length(reconstructed - truth);
      measured.add(error, error / rayLength);
      double step = depthStepDistance(t, rayLength, n, f);
      predicted.add(step, step / rayLength);
    }
  }
  if (sky > 0) {
    return makeError(std::to_string(sky) + " pixels kept the cleared depth (the plane was not drawn)");
  }
  return std::pair{measured.done(), predicted.done()};
}

// The result around the points: the method, where the measured and the
// predicted error reach the threshold, and the charts.
json depthReport(const DepthSweepSpec& spec, const json& points) {
  // The ratio axis varies far (far_over_near given, near fixed) or near (far given).
  const std::string fixedEnd = spec.byRatio() ? "near" : "far";
  auto along = [&](const std::string& metric) {
    return failsAtByAxis(
        {{"distance", failsAt(points, "distance", {"near", "far"}, metric, spec)},
         {"far_over_near", failsAt(points, "far_over_near", {"distance", fixedEnd}, metric, spec)}});
  };
  // The charts of the dashboard: the measured error the threshold applies
  // to, against each swept axis, one line per group that fails_at states a
  // value for. Both axes span decades.
  const std::string errorPath = spec.relativeThreshold ? "error.max_relative" : "error.max_abs";
  const std::string errorLabel =
      spec.relativeThreshold ? "max error / distance from the eye" : "max error (m)";
  return {
      {"renderer", spec.renderer},
      {"parameters",
       spec.byRatio() ? json{"near", "far_over_near", "distance"} : json{"near", "far", "distance"}},
      {"resolution", {spec.resolution.width, spec.resolution.height}},
      {"method",
       {{"depth_format", "D32_SFLOAT_S8_UINT"},
        {"projection", "perspective, depth [0, 1] with far = 1, finite far, not reversed"},
        {"reconstruction", "lighting.frag.glsl worldFromDepth (common.h): invViewProj * (ndc, depth, 1) / w"},
        {"scene",
         "one plane at each distance (view depth at the screen centre), tilted so view depth spans "
         "distance / (1 +- tilt) over the screen"},
        {"tilt", kTilt},
        {"fov_deg", spec.fovDeg}}},
      {"threshold",
       spec.relativeThreshold ? json{{"relative", spec.threshold}} : json{{"absolute", spec.threshold}}},
      {"fails_at", along("error")},
      {"predicted_fails_at", along("predicted")},
      {"plots", json::array({plot("Position error against distance", "distance", errorPath, true, errorLabel,
                                  {"near", "far"}, spec.threshold),
                             plot("Position error against far / near", "far_over_near", errorPath, true,
                                  errorLabel, {"distance", fixedEnd}, spec.threshold)})},
  };
}

}  // namespace

Result<json> runDepthSweep(gpu::Context& ctx, const DepthSweepSpec& spec, const SweepOptions& options) {
  const VkExtent2D extent = {spec.resolution.width, spec.resolution.height};
  const auto ranges = spec.ranges();
  SweepRun run(ctx, options, ranges.size() * spec.distances.size());
  const scenes::Camera camera = headOn(spec.fovDeg);
  const double tanHalf = std::tan(glm::radians(double(camera.fovDeg)) / 2.0);
  const double aspect = double(float(extent.width) / float(extent.height));

  for (double distance : spec.distances) {
    // a, b: the view depth changes by kTilt / 2 of d from the centre to each edge.
    const Plane plane{distance, 0.5 * kTilt / (tanHalf * aspect), 0.5 * kTilt / tanHalf};
    auto ran = run.withScene(
        planeScene(plane, tanHalf, aspect), "distance " + num(distance),
        [&](const renderers::GpuScene& gpuScene) -> Result<bool> {
          for (const auto& range : ranges) {
            std::string where = spec.renderer + " near " + num(range.near) + " far " + num(range.far) +
                                " distance " + num(distance);
            run.next(where);
            const DepthPoint at{plane, camera, extent, {float(range.near), float(range.far)}};
            auto renderer =
                setUpRenderer(ctx, spec.renderer, gpuScene,
                              renderers::RendererOptions{extent, false, spirv::Mode{}, 0, at.depthRange});
            if (!renderer) return makeError(where + ": " + renderer.error());
            (*renderer)->renderFrame(camera);
            std::vector<float> depth = (*renderer)->depthImage();
            (*renderer)->destroy();
            if (depth.size() != size_t(extent.width) * extent.height) {
              return makeError(where + ": the renderer has no depth to read");
            }
            auto error = reconstructionError(at, depth);
            if (!error) return makeError(where + ": " + error.error());
            const auto& [m, p] = *error;
            const double n = double(at.depthRange.zNear), f = double(at.depthRange.zFar);
            run.points.push_back({{"near", range.near},
                                  {"far", range.far},
                                  {"far_over_near", range.far / range.near},
                                  {"distance", distance},
                                  {"depth", depthOf(distance, n, f)},  // at the screen centre
                                  {"error", m.toJson()},
                                  {"predicted", p.toJson()},
                                  {"error_over_predicted", p.maxAbs > 0 ? m.maxAbs / p.maxAbs : 0.0}});
          }
          return true;
        });
    if (!ran) return ran.failure();
  }
  json report = depthReport(spec, run.points);
  return run.finish(kDepthSweepName, spec.source, std::move(report));
}

}  // namespace tally::sweeps
