#include "sweeps/precision.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "analysis/image.hpp"
#include "renderers/gpu_scene.hpp"
#include "shared.h"
#include "sweeps/fields.hpp"
#include "sweeps/precision_plane.hpp"
#include "sweeps/skeleton.hpp"

namespace tally::sweeps {

using analysis::compareImages;
namespace {

using nlohmann::json;
using renderers::BarycentricEncoding;
using renderers::UvDerivativeEncoding;
using renderers::VisibilityEncoding;

constexpr double kUnorm16Steps = 65535.0;

using fields::num;
using precision_plane::Plane;
using precision_plane::planeAt;
using precision_plane::UvMap;
using precision_plane::uvMapOf;
using precision_plane::View;
using precision_plane::viewOf;

// The uv derivatives across one pixel at pixel (x, y), from the ray-plane
// intersection in double: the ray through the pixel centre has view-space
// slopes (X, Y) and meets the plane at depth t = d / (1 + a X + b Y), at
// world (t X, t Y). One pixel right is dX = 2 tan / H; one pixel down (the
// projection flips y) is dY = -2 tan / H.
struct Derivatives {
  glm::dvec2 dx, dy;
};

Derivatives modelDerivatives(const View& v, const Plane& p, const UvMap& uv, uint32_t x, uint32_t y) {
  const double ndcX = (double(x) + 0.5) / v.width * 2.0 - 1.0,
               ndcY = (double(y) + 0.5) / v.height * 2.0 - 1.0;
  const double X = ndcX * v.tanHalf * v.aspect, Y = -ndcY * v.tanHalf;
  const double t = p.d / (1.0 + p.a * X + p.b * Y);
  const double dtdX = -t * t * p.a / p.d, dtdY = -t * t * p.b / p.d;
  const double stepX = 2.0 * v.tanHalf * v.aspect / v.width, stepY = -2.0 * v.tanHalf / v.height;
  const glm::dvec2 worldDx = stepX * glm::dvec2(t + X * dtdX, Y * dtdX);
  const glm::dvec2 worldDy = stepY * glm::dvec2(X * dtdY, t + Y * dtdY);
  return {uv(worldDx), uv(worldDy)};
}

// packUnorm2x16 of one component, decoded: clamped to [0, 1], nearest step.
double unorm16(double c) { return std::round(std::clamp(c, 0.0, 1.0) * kUnorm16Steps) / kUnorm16Steps; }

// What one render left: the final image and the two visibility targets.
struct Rendered {
  std::vector<uint8_t> image, ids, derivatives;
  uint32_t idStride = 0, derivativeStride = 0;  // bytes per texel
  std::string idFormat, derivativeFormat, barycentricSource;
};

Result<Rendered> render(gpu::Context& ctx, const renderers::GpuScene& gpuScene, const scenes::Camera& camera,
                        const View& v, renderers::DepthRange range, const VisibilityEncoding& encoding) {
  auto made = renderers::makeRenderer("visbuffer");
  if (!made) return made.failure();
  renderers::Renderer& r = **made;
  renderers::RendererOptions ro;
  ro.extent = {v.width, v.height};
  ro.instrumented = false;  // counts are not measured here; the image is the same
  ro.lights = 0;            // ambient x diffuse only: the texture decides the image
  ro.depthRange = range;
  ro.visibility = encoding;
  auto ok = r.setup(ctx, gpuScene, ro);
  if (!ok) return ok.failure();
  r.renderFrame(camera);
  Rendered out;
  out.image = r.finalImage();
  out.ids = r.targetBytes("visibility.id");
  out.derivatives = r.targetBytes("visibility.uv_derivatives");
  for (const auto& res : r.resources()) {
    if (res.name == "visibility.id") {
      out.idStride = res.elementBytes;
      out.idFormat = res.formatName;
    } else if (res.name == "visibility.uv_derivatives") {
      out.derivativeStride = res.elementBytes;
      out.derivativeFormat = res.formatName;
    }
  }
  out.barycentricSource = r.notes().value("barycentrics", "");
  r.destroy();
  const size_t pixels = size_t(v.width) * v.height;
  if (out.idStride < 8 || out.derivativeStride < 8 || out.ids.size() != pixels * out.idStride ||
      out.derivatives.size() != pixels * out.derivativeStride || out.image.size() != pixels * 4) {
    return makeError("the visibility targets or the final image could not be read back");
  }
  return out;
}

uint32_t wordAt(const std::vector<uint8_t>& bytes, size_t pixel, uint32_t stride, uint32_t word) {
  uint32_t w = 0;
  std::memcpy(&w, bytes.data() + pixel * stride + word * sizeof(uint32_t), sizeof w);  // little-endian hosts
  return w;
}

// The stored barycentrics (b1, b2) of a pixel, decoded as the shading pass does.
glm::dvec2 barycentricsAt(const Rendered& r, BarycentricEncoding e, size_t pixel) {
  if (e == BarycentricEncoding::Float32) {
    return {std::bit_cast<float>(wordAt(r.ids, pixel, r.idStride, 1)),
            std::bit_cast<float>(wordAt(r.ids, pixel, r.idStride, 2))};
  }
  return glm::dvec2(glm::unpackUnorm2x16(wordAt(r.ids, pixel, r.idStride, 1)));
}

Derivatives derivativesAt(const Rendered& r, UvDerivativeEncoding e, size_t pixel) {
  auto word = [&](uint32_t i) { return wordAt(r.derivatives, pixel, r.derivativeStride, i); };
  switch (e) {
    case UvDerivativeEncoding::Float32:
      return {{std::bit_cast<float>(word(0)), std::bit_cast<float>(word(1))},
              {std::bit_cast<float>(word(2)), std::bit_cast<float>(word(3))}};
    case UvDerivativeEncoding::Unorm16Clamped:
      return {glm::dvec2(glm::unpackUnorm2x16(word(0))), glm::dvec2(glm::unpackUnorm2x16(word(1)))};
    case UvDerivativeEncoding::Half: break;
  }
  return {glm::dvec2(glm::unpackHalf2x16(word(0))), glm::dvec2(glm::unpackHalf2x16(word(1)))};
}

bool hasNegative(const Derivatives& d) { return d.dx.x < 0 || d.dx.y < 0 || d.dy.x < 0 || d.dy.y < 0; }

struct Stats {
  double max = 0, sum = 0;
  size_t n = 0, over = 0;  // over: values above `cut`
  double cut = std::numeric_limits<double>::infinity();
  void add(double v) {
    max = std::max(max, v);
    sum += v;
    ++n;
    if (v > cut) ++over;
  }
  double mean() const { return n ? sum / double(n) : 0.0; }
  double overFraction() const { return n ? double(over) / double(n) : 0.0; }
};

json encodingJson(const VisibilityEncoding& e) {
  return {{"barycentrics", toString(e.barycentrics)}, {"uv_derivatives", toString(e.uvDerivatives)}};
}

// The metrics a point reaches the threshold with, in a fixed order.
json failedMetrics(const json& point, const PrecisionSweepSpec& spec) {
  json out = json::array();
  if (point["error"]["image"]["max_abs"].get<double>() >= spec.imageThreshold) out.push_back("image_max_abs");
  if (point["error"]["mip_level"]["max_abs"].get<double>() >= spec.mipThreshold) out.push_back("mip_level");
  return out;
}

}  // namespace

double mipLevelOf(glm::dvec2 dx, glm::dvec2 dy, uint32_t textureSize, uint32_t levels) {
  const double rho = std::max(glm::length(dx), glm::length(dy)) * double(textureSize);
  if (!(rho > 0)) return 0.0;
  return std::clamp(std::log2(rho), 0.0, double(levels - 1));
}

double unorm16BarycentricBound() { return 0.5 / kUnorm16Steps + std::ldexp(1.0, -24); }

double barycentricUvBound(glm::dvec2 e1, glm::dvec2 e2, uint32_t textureSize) {
  return unorm16BarycentricBound() * (glm::length(e1) + glm::length(e2)) * double(textureSize);
}

double halfMipLevelBound(uint32_t textureSize) {
  const double widen = std::sqrt(1.0 + std::pow(double(textureSize) * std::ldexp(1.0, -14), 2.0));
  return -std::log2(1.0 - std::ldexp(1.0, -11) * widen);
}

namespace {

// What the model says at one distance before any render: the texels per
// pixel at the screen centre, and what the study's packing makes of the
// model's derivatives.
struct DistanceModel {
  double rhoCentre = 0;
  Stats studyModel;
  size_t modelNegative = 0;
  renderers::DepthRange range;
};

DistanceModel modelAt(const PrecisionSweepSpec& spec, const View& v, double distance) {
  const Plane plane = planeAt(v, distance);
  const UvMap uvMap = uvMapOf(spec);
  const uint32_t levels = spec.levels();
  DistanceModel out;
  // Texels per pixel and level at the screen centre, where the plane faces
  // the camera at distance d: a pixel spans 2 d tan / H metres.
  out.rhoCentre = 2.0 * distance * v.tanHalf / v.height * spec.texelsPerMetre;
  // The model's derivatives per pixel, and what each packing makes of them.
  for (uint32_t y = 0; y < v.height; ++y) {
    for (uint32_t x = 0; x < v.width; ++x) {
      const Derivatives m = modelDerivatives(v, plane, uvMap, x, y);
      const Derivatives q = {{unorm16(m.dx.x), unorm16(m.dx.y)}, {unorm16(m.dy.x), unorm16(m.dy.y)}};
      out.studyModel.add(std::abs(mipLevelOf(q.dx, q.dy, spec.textureSize, levels) -
                                  mipLevelOf(m.dx, m.dy, spec.textureSize, levels)));
      if (hasNegative(m)) ++out.modelNegative;
    }
  }
  out.range = {float(distance / 2), float(distance * 2)};  // the plane spans d / 1.1 .. d / 0.9
  return out;
}

// The reference render of one point, its mip level per pixel and the
// barycentric bound of its largest triangle.
struct Reference {
  Rendered frame;
  std::vector<double> level;
  double edgeBound = 0;
};

Result<Reference> referenceOf(Rendered frame, const scenes::Mesh& mesh, const PrecisionSweepSpec& spec,
                              const std::string& where) {
  const size_t pixels = size_t(spec.resolution.width) * spec.resolution.height;
  Reference out{std::move(frame), std::vector<double>(pixels), 0.0};
  size_t covered = 0;
  for (size_t i = 0; i < pixels; ++i) {
    if (wordAt(out.frame.ids, i, out.frame.idStride, 0) == shaders::kVisibilityClear) continue;
    ++covered;
    const Derivatives d = derivativesAt(out.frame, UvDerivativeEncoding::Float32, i);
    out.level[i] = mipLevelOf(d.dx, d.dy, spec.textureSize, spec.levels());
  }
  if (covered != pixels) {
    return makeError(where + ": " + std::to_string(pixels - covered) +
                     " pixels kept the cleared id (the plane was not drawn)");
  }
  // The largest uv edge sum of any triangle, for the barycentric bound.
  for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
    const glm::dvec2 u0(mesh.vertices[mesh.indices[t]].uv), u1(mesh.vertices[mesh.indices[t + 1]].uv),
        u2(mesh.vertices[mesh.indices[t + 2]].uv);
    out.edgeBound = std::max(out.edgeBound, barycentricUvBound(u1 - u0, u2 - u0, spec.textureSize));
  }
  return out;
}

// A variant's errors against the reference, pixel by pixel.
struct VariantErrors {
  Stats mip, uvTexels, uvInRange;
  size_t mismatched = 0, clamped = 0, outOfRange = 0;
};

Result<VariantErrors> variantErrors(const Reference& ref, const Rendered& got,
                                    const VisibilityEncoding& encoding, const scenes::Mesh& mesh,
                                    uint32_t textureSize, uint32_t levels) {
  VariantErrors e;
  e.mip.cut = 0.5;  // half a level: the nearest level changes
  for (size_t i = 0; i < ref.level.size(); ++i) {
    const uint32_t id = wordAt(got.ids, i, got.idStride, 0);
    if (id != wordAt(ref.frame.ids, i, ref.frame.idStride, 0)) {
      ++e.mismatched;  // another triangle: barycentrics are not comparable
      continue;
    }
    const Derivatives d = derivativesAt(got, encoding.uvDerivatives, i);
    e.mip.add(std::abs(mipLevelOf(d.dx, d.dy, textureSize, levels) - ref.level[i]));
    if (encoding.uvDerivatives == UvDerivativeEncoding::Unorm16Clamped &&
        hasNegative(derivativesAt(ref.frame, UvDerivativeEncoding::Float32, i))) {
      ++e.clamped;
    }
    // uv = u0 + b1 (u1 - u0) + b2 (u2 - u0): the error is the barycentric
    // error along the triangle's uv edges.
    const uint32_t t = shaders::visibilityTriangleId(id);
    if (size_t(t) * 3 + 2 >= mesh.indices.size()) return makeError("id names no triangle");
    const glm::dvec2 u0(mesh.vertices[mesh.indices[t * 3]].uv), u1(mesh.vertices[mesh.indices[t * 3 + 1]].uv),
        u2(mesh.vertices[mesh.indices[t * 3 + 2]].uv);
    const glm::dvec2 refB = barycentricsAt(ref.frame, BarycentricEncoding::Float32, i);
    const glm::dvec2 db = barycentricsAt(got, encoding.barycentrics, i) - refB;
    const double uvError = glm::length(db.x * (u1 - u0) + db.y * (u2 - u0)) * double(textureSize);
    e.uvTexels.add(uvError);
    // Barycentrics of a pixel the rasteriser gives a triangle can fall
    // just outside [0, 1] (computed ones come from the unsnapped
    // vertices): unorm16 clamps them, an error beside the rounding.
    if (refB.x < 0 || refB.y < 0 || refB.x > 1 || refB.y > 1) {
      ++e.outOfRange;
    } else {
      e.uvInRange.add(uvError);
    }
  }
  return e;
}

// The mip-level error a packing of the derivatives should make: none, the
// half-float bound, or the model's for the study's clamped unorm16.
json predictedMip(UvDerivativeEncoding encoding, const DistanceModel& model, uint32_t textureSize,
                  size_t pixels) {
  switch (encoding) {
    case UvDerivativeEncoding::Float32: break;
    case UvDerivativeEncoding::Half:
      return {{"max_abs", halfMipLevelBound(textureSize)}, {"mean_abs", nullptr}, {"clamped_fraction", 0.0}};
    case UvDerivativeEncoding::Unorm16Clamped:
      return {{"max_abs", model.studyModel.max},
              {"mean_abs", model.studyModel.mean()},
              {"clamped_fraction", double(model.modelNegative) / double(pixels)}};
  }
  return {{"max_abs", 0.0}, {"mean_abs", 0.0}, {"clamped_fraction", 0.0}};
}

// One point: a variant at one distance and triangle size, measured against
// the reference beside what the bounds and the model predict.
struct PointAt {
  double distance = 0, triangleSize = 0;
  std::string where;  // "distance 4 triangle size 1", for errors
  const DistanceModel& model;
  const scenes::Mesh& mesh;
  const Reference& ref;
};

Result<json> variantPoint(const PrecisionSweepSpec& spec, const PointAt& at, const PrecisionVariant& variant,
                          const Rendered& got) {
  const auto& [distance, size, where, model, mesh, ref] = at;
  const View v = viewOf(spec);
  const uint32_t levels = spec.levels();
  const size_t pixels = ref.level.size();
  auto image = compareImages(ref.frame.image, got.image, v.width, v.height);
  if (!image) return makeError(where + " " + variant.name + ": " + image.error());
  size_t differing = 0;
  for (size_t i = 0; i < pixels; ++i) {
    const uint8_t* a = &ref.frame.image[i * 4];
    const uint8_t* b = &got.image[i * 4];
    if (a[0] != b[0] || a[1] != b[1] || a[2] != b[2]) ++differing;
  }
  auto errors = variantErrors(ref, got, variant.encoding, mesh, spec.textureSize, levels);
  if (!errors) return makeError(where + ": " + errors.error());
  const VariantErrors& e = *errors;
  const size_t compared = pixels - e.mismatched;
  const bool unormBary = variant.encoding.barycentrics == BarycentricEncoding::Unorm16;
  json point = {
      {"distance", distance},
      {"triangle_size", size},
      {"variant", variant.name},
      {"barycentrics", toString(variant.encoding.barycentrics)},
      {"uv_derivatives", toString(variant.encoding.uvDerivatives)},
      {"triangles", mesh.triangleCount()},
      {"texels_per_pixel", model.rhoCentre},
      {"level", std::clamp(std::log2(model.rhoCentre), 0.0, double(levels - 1))},
      {"pixels", pixels},
      {"id_mismatches", e.mismatched},
      {"error",
       {{"image",
         {{"max_abs", image->maxAbs},
          {"mean_abs", image->meanAbs},
          {"psnr", std::isfinite(image->psnr) ? json(image->psnr) : json(nullptr)},
          {"differing_fraction", double(differing) / double(pixels)}}},
        {"mip_level",
         {{"max_abs", e.mip.max},
          {"mean_abs", e.mip.mean()},
          {"fraction_over_half", e.mip.overFraction()},
          {"clamped_fraction", compared ? double(e.clamped) / double(compared) : 0.0}}},
        {"uv_texels",
         {{"max", e.uvTexels.max},
          {"mean", e.uvTexels.mean()},
          {"max_in_range", e.uvInRange.max},
          {"mean_in_range", e.uvInRange.mean()},
          {"out_of_range_fraction", compared ? double(e.outOfRange) / double(compared) : 0.0}}}}},
      {"predicted",
       {{"mip_level", predictedMip(variant.encoding.uvDerivatives, model, spec.textureSize, pixels)},
        {"uv_texels", {{"max", unormBary ? ref.edgeBound : 0.0}}}}},
  };
  point["fails"] = failedMetrics(point, spec);
  return point;
}

// The result around the points: the method (encodings, the formats the
// renderer chose, the texture and the scene), where the points start to
// fail along each axis, and the charts.
json precisionReport(const PrecisionSweepSpec& spec, const json& points, const json& formats,
                     const std::string& barycentricSource) {
  json variantList = json::array();
  for (const auto& variant : precisionVariants()) {
    json e = encodingJson(variant.encoding);
    e["variant"] = variant.name;
    variantList.push_back(e);
  }
  // Per group of points that differ only in one axis, the smallest value of
  // it whose image or mip-level error reaches the threshold, and which
  // metrics did there.
  auto fails = [](const json& p) { return !p["fails"].empty(); };
  return {
      {"renderer", "visbuffer"},
      {"parameters", {"distance", "triangle_size", "variant"}},
      {"resolution", {spec.resolution.width, spec.resolution.height}},
      {"method",
       {{"reference", encodingJson(precisionReference().encoding)},
        {"variants", variantList},
        {"formats", formats},
        {"barycentrics", barycentricSource},
        {"texture_size", spec.textureSize},
        {"levels", spec.levels()},
        {"texels_per_metre", spec.texelsPerMetre},
        {"uv_rotation_deg", spec.uvRotationDeg},
        {"uv",
         "(texels_per_metre / texture_size) R(uv_rotation) (x, -y): at rotation 0 u runs right, v down"},
        {"level_of_detail", "log2(max(|dFdx(uv)|, |dFdy(uv)|) x texture_size), clamped to [0, levels - 1]"},
        {"scene",
         "one plane per distance (view depth at the screen centre), tilted so view depth spans "
         "distance / (1 +- tilt), tiled with right triangles of the given leg along x and y; "
         "diffuse map with a distinct colour per mip level and a texel checker"},
        {"shading", "no point lights: ambient x diffuse, then tonemap"},
        {"tilt", kPrecisionTilt},
        {"fov_deg", spec.fovDeg}}},
      {"threshold", {{"image_max_abs", spec.imageThreshold}, {"mip_level", spec.mipThreshold}}},
      {"fails_at",
       failsAtByAxis(
           {{"distance", smallestFailing(points, "distance", {"variant", "triangle_size"}, fails, "fails")},
            {"triangle_size",
             smallestFailing(points, "triangle_size", {"variant", "distance"}, fails, "fails")}})},
      {"plots",
       json::array(
           {plot("Image error against distance", "distance", "error.image.max_abs", false,
                 "max |difference| (8-bit levels)", {"variant", "triangle_size"}, spec.imageThreshold),
            plot("Mip-level error against distance", "distance", "error.mip_level.max_abs", false,
                 "max |level - reference level| (levels)", {"variant", "triangle_size"}, spec.mipThreshold),
            plot("uv error from the barycentrics against triangle size", "triangle_size",
                 "error.uv_texels.max", true, "max uv error (texels)", {"variant", "distance"}, nullptr)})},
  };
}

}  // namespace

Result<json> runPrecisionSweep(gpu::Context& ctx, const PrecisionSweepSpec& spec,
                               const SweepOptions& options) {
  const View v = viewOf(spec);
  const auto variants = precisionVariants();
  const PrecisionVariant reference = precisionReference();
  const scenes::Camera camera = precisionCamera(spec);
  SweepRun run(ctx, options, spec.distances.size() * spec.triangleSizes.size() * (variants.size() + 1));
  json formats = json::object();
  std::string barycentricSource;
  auto noteFormats = [&](const std::string& name, const Rendered& r) {
    formats[name] = {{"visibility.id", r.idFormat}, {"visibility.uv_derivatives", r.derivativeFormat}};
  };

  for (double distance : spec.distances) {
    const DistanceModel model = modelAt(spec, v, distance);
    for (double size : spec.triangleSizes) {
      const std::string where = "distance " + num(distance) + " triangle size " + num(size);
      auto scene = precisionScene(spec, distance, size);
      if (!scene) return makeError(where + ": " + scene.error());
      const scenes::Mesh& mesh = scene->meshes.front();
      auto ran = run.withScene(*scene, where, [&](const renderers::GpuScene& gpuScene) -> Result<bool> {
        run.next(where + " reference");
        auto rendered = render(ctx, gpuScene, camera, v, model.range, reference.encoding);
        if (!rendered) return makeError(where + " reference: " + rendered.error());
        barycentricSource = rendered->barycentricSource;
        noteFormats(reference.name, *rendered);
        auto ref = referenceOf(std::move(*rendered), mesh, spec, where);
        if (!ref) return ref.failure();
        const PointAt at{distance, size, where, model, mesh, *ref};
        for (const auto& variant : variants) {
          run.next(where + " " + variant.name);
          auto got = render(ctx, gpuScene, camera, v, model.range, variant.encoding);
          if (!got) return makeError(where + " " + variant.name + ": " + got.error());
          noteFormats(variant.name, *got);
          auto point = variantPoint(spec, at, variant, *got);
          if (!point) return point.failure();
          run.points.push_back(std::move(*point));
        }
        return true;
      });
      if (!ran) return ran.failure();
    }
  }
  json report = precisionReport(spec, run.points, formats, barycentricSource);
  return run.finish(kPrecisionSweepName, spec.source, std::move(report));
}

}  // namespace tally::sweeps
