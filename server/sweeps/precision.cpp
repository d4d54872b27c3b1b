#include "sweeps/precision.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <map>

#include "analysis/image.hpp"
#include "sweeps/fields.hpp"
#include "renderers/gpu_scene.hpp"
#include "scenes/mesh_builder.hpp"
#include "shared.h"

namespace tally::sweeps {

using analysis::compareImages;
namespace {

using nlohmann::json;
using renderers::BarycentricEncoding;
using renderers::UvDerivativeEncoding;
using renderers::VisibilityEncoding;

constexpr double kUnorm16Steps = 65535.0;

using fields::fieldError;
using fields::num;
using fields::show;



// A non-empty array of distinct positive finite numbers.
Result<std::vector<double>> positiveList(const json& j, const std::string& field) {
  if (!j.is_array() || j.empty() || j.size() > kMaxPrecisionAxis) {
    return fieldError(
        field, "must be an array of 1 to " + std::to_string(kMaxPrecisionAxis) + " numbers, got " + show(j));
  }
  std::vector<double> out;
  for (size_t i = 0; i < j.size(); ++i) {
    std::string f = field + "[" + std::to_string(i) + "]";
    if (!j[i].is_number() || !std::isfinite(j[i].get<double>()) || j[i].get<double>() <= 0 ||
        j[i].get<double>() > 1e6) {
      return fieldError(f, "must be a number in (0, 1e6] metres, got " + show(j[i]));
    }
    double v = j[i].get<double>();
    if (std::find(out.begin(), out.end(), v) != out.end()) return fieldError(f, num(v) + " listed twice");
    out.push_back(v);
  }
  return out;
}

// A finite number in [lo, hi] (or (lo, hi] when `openLow`).
Result<double> numberIn(const json& j, const std::string& field, double lo, double hi, bool openLow) {
  if (!j.is_number() || !std::isfinite(j.get<double>()) || j.get<double>() > hi ||
      (openLow ? j.get<double>() <= lo : j.get<double>() < lo)) {
    return fieldError(field, "must be a number in " + std::string(openLow ? "(" : "[") + num(lo) + ", " +
                                 num(hi) + "], got " + show(j));
  }
  return j.get<double>();
}

uint32_t hashTexel(uint32_t x, uint32_t y, uint32_t seed) {
  uint32_t h = x * 0x8da6b343u ^ y * 0xd8163841u ^ seed * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

// The view: camera at the origin looking down -Z, square pixels.
struct View {
  uint32_t width = 0, height = 0;
  double tanHalf = 0, aspect = 0;
};

View viewOf(const PrecisionSweepSpec& spec) {
  View v;
  v.width = spec.resolution.width;
  v.height = spec.resolution.height;
  v.tanHalf = std::tan(glm::radians(spec.fovDeg) / 2.0);
  v.aspect = double(float(v.width) / float(v.height));  // as the projection gets it
  return v;
}

// The plane z = -d + a x + b y: view depth changes by kPrecisionTilt / 2 of d
// from the centre to each edge (as the depth sweep's).
struct Plane {
  double d = 0, a = 0, b = 0;
};

Plane planeAt(const View& v, double distance) {
  return {distance, 0.5 * kPrecisionTilt / (v.tanHalf * v.aspect), 0.5 * kPrecisionTilt / v.tanHalf};
}

// Half-extents of the plane: at the margin it lies nearer than d / (1 - 2
// tilt), and 1.5x the view there covers every pixel.
glm::dvec2 planeHalfExtent(const View& v, double distance) {
  const double halfY = distance / (1.0 - 2 * kPrecisionTilt) * v.tanHalf * 1.5;
  return {halfY * v.aspect, halfY};
}

// The grid of `size` cells covering the plane: cell columns [i0, i1), rows [j0, j1).
struct Grid {
  double i0 = 0, i1 = 0, j0 = 0, j1 = 0;
  double triangles() const { return 2.0 * (i1 - i0) * (j1 - j0); }
};

Grid gridOf(const View& v, double distance, double size) {
  const glm::dvec2 half = planeHalfExtent(v, distance);
  return {std::floor(-half.x / size), std::ceil(half.x / size), std::floor(-half.y / size),
          std::ceil(half.y / size)};
}

Error tooManyTriangles(const std::string& field, double size, double distance, double triangles) {
  return fieldError(field, "legs of " + num(size) + " m tile the plane at distance " + num(distance) +
                               " with " + num(triangles) + " triangles, more than the limit of " +
                               std::to_string(kMaxPrecisionTriangles));
}

// uv of world (x, y): scale R(rotation) (x, -y).
struct UvMap {
  double scale = 0, c = 1, s = 0;
  glm::dvec2 operator()(glm::dvec2 p) const {
    const double x = p.x, y = -p.y;
    return scale * glm::dvec2(c * x - s * y, s * x + c * y);
  }
};

UvMap uvMapOf(const PrecisionSweepSpec& spec) {
  const double r = glm::radians(spec.uvRotationDeg);
  return {spec.texelsPerMetre / double(spec.textureSize), std::cos(r), std::sin(r)};
}

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

// Per group of points that differ only in `param`, the smallest value of it
// whose image or mip-level error reaches the threshold, and which metrics
// did there; null where none does. Null overall when no point fails.
json failsAt(const json& points, const std::string& param, const std::vector<std::string>& groupBy) {
  std::map<std::string, json> groups;
  std::vector<std::string> order;
  bool any = false;
  for (const auto& p : points) {
    json key = json::array();
    for (const auto& g : groupBy) key.push_back(p[g]);
    auto [it, inserted] = groups.try_emplace(key.dump());
    if (inserted) {
      order.push_back(key.dump());
      for (const auto& g : groupBy) it->second[g] = p[g];
      it->second[param] = nullptr;
      it->second["metrics"] = nullptr;
    }
    if (p["fails"].empty()) continue;
    any = true;
    double v = p[param].get<double>();
    if (it->second[param].is_null() || v < it->second[param].get<double>()) {
      it->second[param] = v;
      it->second["metrics"] = p["fails"];
    }
  }
  if (!any) return nullptr;
  json out = json::array();
  for (const auto& k : order) out.push_back(groups[k]);
  return out;
}

}  // namespace

uint32_t PrecisionSweepSpec::levels() const { return uint32_t(std::countr_zero(textureSize)) + 1; }

Result<PrecisionSweepSpec> parsePrecisionSweepSpec(const json& j) {
  if (!j.is_object()) return fieldError("spec", "must be a JSON object, got " + show(j));
  if (auto e =
          json_fields::unknownKey(j, "",
                                  {"sweep", "distances", "triangle_sizes", "texture_size", "texels_per_metre",
                                   "uv_rotation_deg", "resolution", "fov_deg", "threshold"}))
    return *e;
  PrecisionSweepSpec spec;
  spec.source = j;

  if (!j.contains("distances")) return fieldError("distances", "required, e.g. [2, 8, 32]");
  auto distances = positiveList(j["distances"], "distances");
  if (!distances) return distances.failure();
  spec.distances = *distances;
  if (!j.contains("triangle_sizes")) return fieldError("triangle_sizes", "required, e.g. [0.25, 1, 4]");
  auto sizes = positiveList(j["triangle_sizes"], "triangle_sizes");
  if (!sizes) return sizes.failure();
  spec.triangleSizes = *sizes;

  if (j.contains("texture_size")) {
    const auto& t = j["texture_size"];
    const bool integer = t.is_number_integer() && t.get<int64_t>() >= kMinPrecisionTexture &&
                         t.get<int64_t>() <= kMaxPrecisionTexture;
    if (!integer || !std::has_single_bit(uint64_t(t.get<int64_t>()))) {
      return fieldError("texture_size", "must be a power of two from " +
                                            std::to_string(kMinPrecisionTexture) + " to " +
                                            std::to_string(kMaxPrecisionTexture) + ", got " + show(t));
    }
    spec.textureSize = uint32_t(t.get<int64_t>());
  }
  if (j.contains("texels_per_metre")) {
    auto v = numberIn(j["texels_per_metre"], "texels_per_metre", 0.0, 1e6, true);
    if (!v) return v.failure();
    spec.texelsPerMetre = *v;
  }
  if (j.contains("uv_rotation_deg")) {
    auto v = numberIn(j["uv_rotation_deg"], "uv_rotation_deg", -360.0, 360.0, false);
    if (!v) return v.failure();
    spec.uvRotationDeg = *v;
  }
  if (j.contains("resolution")) {
    auto r = fields::resolution(j["resolution"]);
    if (!r) return r.failure();
    spec.resolution = *r;
  }
  if (j.contains("fov_deg")) {
    auto v = numberIn(j["fov_deg"], "fov_deg", 1.0, 170.0, false);
    if (!v) return v.failure();
    spec.fovDeg = *v;
  }
  if (j.contains("threshold")) {
    const auto& t = j["threshold"];
    if (!t.is_object()) {
      return fieldError("threshold",
                        "must be {\"image_max_abs\": levels, \"mip_level\": levels}, got " + show(t));
    }
    if (auto e = json_fields::unknownKey(t, "threshold", {"image_max_abs", "mip_level"})) return *e;
    if (t.contains("image_max_abs")) {
      auto v = numberIn(t["image_max_abs"], "threshold.image_max_abs", 0.0, 255.0, true);
      if (!v) return v.failure();
      spec.imageThreshold = *v;
    }
    if (t.contains("mip_level")) {
      auto v = numberIn(t["mip_level"], "threshold.mip_level", 0.0, 16.0, true);
      if (!v) return v.failure();
      spec.mipThreshold = *v;
    }
  }

  const size_t renders = spec.distances.size() * spec.triangleSizes.size() * (precisionVariants().size() + 1);
  if (renders > kMaxPrecisionRenders) {
    return fieldError("spec", "distances x triangle_sizes x " +
                                  std::to_string(precisionVariants().size() + 1) + " encodings is " +
                                  std::to_string(renders) + " renders, more than the limit of " +
                                  std::to_string(kMaxPrecisionRenders));
  }
  // Every (distance, size) must tessellate within the triangle limit; the
  // grid's size does not depend on the texture, so checking costs nothing.
  const View view = viewOf(spec);
  for (double distance : spec.distances) {
    for (size_t k = 0; k < spec.triangleSizes.size(); ++k) {
      const double triangles = gridOf(view, distance, spec.triangleSizes[k]).triangles();
      if (triangles > double(kMaxPrecisionTriangles)) {
        return tooManyTriangles("triangle_sizes[" + std::to_string(k) + "]", spec.triangleSizes[k], distance,
                                triangles);
      }
    }
  }
  return spec;
}

PrecisionVariant precisionReference() {
  return {"reference", {BarycentricEncoding::Float32, UvDerivativeEncoding::Float32}};
}

std::vector<PrecisionVariant> precisionVariants() {
  return {precisionReference(),
          {"unorm16-barycentrics", {BarycentricEncoding::Unorm16, UvDerivativeEncoding::Float32}},
          {"half-derivatives", {BarycentricEncoding::Float32, UvDerivativeEncoding::Half}},
          {"study-derivatives", {BarycentricEncoding::Float32, UvDerivativeEncoding::Unorm16Clamped}},
          {"tally", {BarycentricEncoding::Unorm16, UvDerivativeEncoding::Half}},
          {"study", {BarycentricEncoding::Unorm16, UvDerivativeEncoding::Unorm16Clamped}}};
}

scenes::Texture precisionTexture(uint32_t size) {
  // Saturated colours, each far from its neighbours in the cycle.
  static const glm::vec3 kLevelColours[] = {{1.0f, 0.16f, 0.16f}, {0.16f, 1.0f, 0.16f}, {0.25f, 0.25f, 1.0f},
                                            {1.0f, 1.0f, 0.16f},  {1.0f, 0.16f, 1.0f},  {0.16f, 1.0f, 1.0f},
                                            {1.0f, 0.6f, 0.16f}};
  constexpr uint32_t kColours = sizeof kLevelColours / sizeof kLevelColours[0];
  auto level = [&](uint32_t l) {
    const uint32_t n = std::max(size >> l, 1u);
    std::vector<uint8_t> texels(size_t(n) * n * 4);
    for (uint32_t y = 0; y < n; ++y) {
      for (uint32_t x = 0; x < n; ++x) {
        const float checker = ((x + y) & 1u) ? 1.0f : 0.35f;
        const float jitter = 0.9f + 0.2f * float(hashTexel(x, y, l) >> 8) * (1.0f / 16777216.0f);
        const glm::vec3 c = glm::clamp(kLevelColours[l % kColours] * checker * jitter, 0.0f, 1.0f);
        uint8_t* t = &texels[(size_t(y) * n + x) * 4];
        for (int i = 0; i < 3; ++i) t[i] = uint8_t(std::lround(c[i] * 255.0f));
        t[3] = 255;
      }
    }
    return texels;
  };
  scenes::Texture t;
  t.name = "precision/diffuse";
  t.width = t.height = size;
  t.srgb = true;
  t.rgba8 = level(0);
  for (uint32_t l = 1; (size >> l) > 0; ++l) t.mips.push_back(level(l));
  return t;
}

Result<scenes::Scene> precisionScene(const PrecisionSweepSpec& spec, double distance, double triangleSize,
                                     const std::string& field) {
  const View v = viewOf(spec);
  const Plane plane = planeAt(v, distance);
  const UvMap uv = uvMapOf(spec);
  const Grid grid = gridOf(v, distance, triangleSize);
  if (grid.triangles() > double(kMaxPrecisionTriangles)) {
    return tooManyTriangles(field, triangleSize, distance, grid.triangles());
  }
  scenes::Scene scene;
  scene.name = "precision-plane";
  scene.textures.push_back(precisionTexture(spec.textureSize));
  scenes::Material material;
  material.name = "precision";
  material.maps[size_t(scenes::MapSlot::Diffuse)] = 0;
  scene.materials.push_back(material);

  const glm::vec3 facing(-float(plane.a), -float(plane.b), 1.0f);
  const glm::vec3 normal = glm::normalize(facing);
  scenes::MeshBuilder b;
  const int64_t nx = int64_t(grid.i1 - grid.i0), ny = int64_t(grid.j1 - grid.j0);
  for (int64_t j = 0; j <= ny; ++j) {
    for (int64_t i = 0; i <= nx; ++i) {
      const double x = (grid.i0 + double(i)) * triangleSize, y = (grid.j0 + double(j)) * triangleSize;
      const glm::vec3 p(float(x), float(y), float(-plane.d + plane.a * x + plane.b * y));
      b.vertex(p, normal, glm::vec2(uv(glm::dvec2(x, y))));
    }
  }
  auto at = [&](int64_t i, int64_t j) { return uint32_t(j * (nx + 1) + i); };
  for (int64_t j = 0; j < ny; ++j) {
    for (int64_t i = 0; i < nx; ++i) {
      // Right angles at (i + 1, j) and (i, j + 1); legs along x and y.
      b.triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1), facing);
      b.triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1), facing);
    }
  }
  scene.meshes.push_back(b.finish("plane", 0));
  scenes::updateBounds(scene);
  return scene;
}

scenes::Camera precisionCamera(const PrecisionSweepSpec& spec) {
  scenes::Camera camera;
  camera.eye = glm::vec3(0.0f);
  camera.target = glm::vec3(0.0f, 0.0f, -1.0f);
  camera.fovDeg = float(spec.fovDeg);
  camera.label = "head-on";
  return camera;
}

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

Result<json> runPrecisionSweep(gpu::Context& ctx, const PrecisionSweepSpec& spec,
                               const SweepOptions& options) {
  const View v = viewOf(spec);
  const UvMap uvMap = uvMapOf(spec);
  const uint32_t levels = spec.levels();
  const size_t pixels = size_t(v.width) * v.height;
  const auto variants = precisionVariants();
  const PrecisionVariant reference = precisionReference();
  const scenes::Camera camera = precisionCamera(spec);
  Progress progress{0, spec.distances.size() * spec.triangleSizes.size() * (variants.size() + 1), ""};
  json formats = json::object();
  std::string barycentricSource;

  json points = json::array();
  for (double distance : spec.distances) {
    const Plane plane = planeAt(v, distance);
    // Texels per pixel and level at the screen centre, where the plane faces
    // the camera at distance d: a pixel spans 2 d tan / H metres.
    const double rhoCentre = 2.0 * distance * v.tanHalf / v.height * spec.texelsPerMetre;
    // The model's derivatives per pixel, and what each packing makes of them.
    std::vector<Derivatives> model(pixels);
    for (uint32_t y = 0; y < v.height; ++y) {
      for (uint32_t x = 0; x < v.width; ++x)
        model[size_t(y) * v.width + x] = modelDerivatives(v, plane, uvMap, x, y);
    }
    Stats studyModel;
    size_t modelNegative = 0;
    for (const auto& m : model) {
      const Derivatives q = {{unorm16(m.dx.x), unorm16(m.dx.y)}, {unorm16(m.dy.x), unorm16(m.dy.y)}};
      studyModel.add(std::abs(mipLevelOf(q.dx, q.dy, spec.textureSize, levels) -
                              mipLevelOf(m.dx, m.dy, spec.textureSize, levels)));
      if (hasNegative(m)) ++modelNegative;
    }
    const renderers::DepthRange range{float(distance / 2),
                                      float(distance * 2)};  // the plane spans d / 1.1 .. d / 0.9

    for (double size : spec.triangleSizes) {
      const std::string where = "distance " + num(distance) + " triangle size " + num(size);
      auto scene = precisionScene(spec, distance, size);
      if (!scene) return makeError(where + ": " + scene.error());
      const scenes::Mesh& mesh = scene->meshes.front();
      renderers::GpuScene gpuScene;
      auto uploaded = gpuScene.upload(ctx, *scene);
      if (!uploaded) return makeError(where + ": " + uploaded.error());

      progress.current = where + " reference";
      if (options.progress) options.progress(progress);
      auto ref = render(ctx, gpuScene, camera, v, range, reference.encoding);
      if (!ref) return makeError(where + " reference: " + ref.error());
      ++progress.done;
      barycentricSource = ref->barycentricSource;
      formats[reference.name] = {{"visibility.id", ref->idFormat},
                                 {"visibility.uv_derivatives", ref->derivativeFormat}};

      // The reference's level per pixel and triangle per pixel.
      std::vector<double> refLevel(pixels);
      size_t covered = 0;
      for (size_t i = 0; i < pixels; ++i) {
        if (wordAt(ref->ids, i, ref->idStride, 0) == shaders::kVisibilityClear) continue;
        ++covered;
        const Derivatives d = derivativesAt(*ref, UvDerivativeEncoding::Float32, i);
        refLevel[i] = mipLevelOf(d.dx, d.dy, spec.textureSize, levels);
      }
      if (covered != pixels) {
        return makeError(where + ": " + std::to_string(pixels - covered) +
                         " pixels kept the cleared id (the plane was not drawn)");
      }
      // The largest uv edge sum of any triangle, for the barycentric bound.
      double edgeBound = 0;
      for (size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        const glm::dvec2 u0(mesh.vertices[mesh.indices[t]].uv), u1(mesh.vertices[mesh.indices[t + 1]].uv),
            u2(mesh.vertices[mesh.indices[t + 2]].uv);
        edgeBound = std::max(edgeBound, barycentricUvBound(u1 - u0, u2 - u0, spec.textureSize));
      }

      for (const auto& variant : variants) {
        progress.current = where + " " + variant.name;
        if (options.progress) options.progress(progress);
        auto got = render(ctx, gpuScene, camera, v, range, variant.encoding);
        if (!got) return makeError(where + " " + variant.name + ": " + got.error());
        ++progress.done;
        formats[variant.name] = {{"visibility.id", got->idFormat},
                                 {"visibility.uv_derivatives", got->derivativeFormat}};

        auto image = compareImages(ref->image, got->image, v.width, v.height);
        if (!image) return makeError(where + " " + variant.name + ": " + image.error());
        size_t differing = 0;
        for (size_t i = 0; i < pixels; ++i) {
          const uint8_t* a = &ref->image[i * 4];
          const uint8_t* b = &got->image[i * 4];
          if (a[0] != b[0] || a[1] != b[1] || a[2] != b[2]) ++differing;
        }

        Stats mip, uvTexels, uvInRange;
        mip.cut = 0.5;  // half a level: the nearest level changes
        size_t mismatched = 0, clamped = 0, outOfRange = 0;
        for (size_t i = 0; i < pixels; ++i) {
          const uint32_t id = wordAt(got->ids, i, got->idStride, 0);
          if (id != wordAt(ref->ids, i, ref->idStride, 0)) {
            ++mismatched;  // another triangle: barycentrics are not comparable
            continue;
          }
          const Derivatives d = derivativesAt(*got, variant.encoding.uvDerivatives, i);
          mip.add(std::abs(mipLevelOf(d.dx, d.dy, spec.textureSize, levels) - refLevel[i]));
          if (variant.encoding.uvDerivatives == UvDerivativeEncoding::Unorm16Clamped &&
              hasNegative(derivativesAt(*ref, UvDerivativeEncoding::Float32, i))) {
            ++clamped;
          }
          // uv = u0 + b1 (u1 - u0) + b2 (u2 - u0): the error is the barycentric
          // error along the triangle's uv edges.
          const uint32_t t = shaders::visibilityTriangleId(id);
          if (size_t(t) * 3 + 2 >= mesh.indices.size()) return makeError(where + ": id names no triangle");
          const glm::dvec2 u0(mesh.vertices[mesh.indices[t * 3]].uv),
              u1(mesh.vertices[mesh.indices[t * 3 + 1]].uv), u2(mesh.vertices[mesh.indices[t * 3 + 2]].uv);
          const glm::dvec2 refB = barycentricsAt(*ref, BarycentricEncoding::Float32, i);
          const glm::dvec2 db = barycentricsAt(*got, variant.encoding.barycentrics, i) - refB;
          const double uvError = glm::length(db.x * (u1 - u0) + db.y * (u2 - u0)) * double(spec.textureSize);
          uvTexels.add(uvError);
          // Barycentrics of a pixel the rasteriser gives a triangle can fall
          // just outside [0, 1] (computed ones come from the unsnapped
          // vertices): unorm16 clamps them, an error beside the rounding.
          if (refB.x < 0 || refB.y < 0 || refB.x > 1 || refB.y > 1) {
            ++outOfRange;
          } else {
            uvInRange.add(uvError);
          }
        }
        const size_t compared = pixels - mismatched;

        // Predictions: the bounds, and the model's levels for the study's packing.
        const bool unormBary = variant.encoding.barycentrics == BarycentricEncoding::Unorm16;
        json predictedMip;
        switch (variant.encoding.uvDerivatives) {
          case UvDerivativeEncoding::Float32:
            predictedMip = {{"max_abs", 0.0}, {"mean_abs", 0.0}, {"clamped_fraction", 0.0}};
            break;
          case UvDerivativeEncoding::Half:
            predictedMip = {{"max_abs", halfMipLevelBound(spec.textureSize)},
                            {"mean_abs", nullptr},
                            {"clamped_fraction", 0.0}};
            break;
          case UvDerivativeEncoding::Unorm16Clamped:
            predictedMip = {{"max_abs", studyModel.max},
                            {"mean_abs", studyModel.mean()},
                            {"clamped_fraction", double(modelNegative) / double(pixels)}};
            break;
        }
        json point = {
            {"distance", distance},
            {"triangle_size", size},
            {"variant", variant.name},
            {"barycentrics", toString(variant.encoding.barycentrics)},
            {"uv_derivatives", toString(variant.encoding.uvDerivatives)},
            {"triangles", mesh.triangleCount()},
            {"texels_per_pixel", rhoCentre},
            {"level", std::clamp(std::log2(rhoCentre), 0.0, double(levels - 1))},
            {"pixels", pixels},
            {"id_mismatches", mismatched},
            {"error",
             {{"image",
               {{"max_abs", image->maxAbs},
                {"mean_abs", image->meanAbs},
                {"psnr", std::isfinite(image->psnr) ? json(image->psnr) : json(nullptr)},
                {"differing_fraction", double(differing) / double(pixels)}}},
              {"mip_level",
               {{"max_abs", mip.max},
                {"mean_abs", mip.mean()},
                {"fraction_over_half", mip.overFraction()},
                {"clamped_fraction", compared ? double(clamped) / double(compared) : 0.0}}},
              {"uv_texels",
               {{"max", uvTexels.max},
                {"mean", uvTexels.mean()},
                {"max_in_range", uvInRange.max},
                {"mean_in_range", uvInRange.mean()},
                {"out_of_range_fraction", compared ? double(outOfRange) / double(compared) : 0.0}}}}},
            {"predicted",
             {{"mip_level", predictedMip}, {"uv_texels", {{"max", unormBary ? edgeBound : 0.0}}}}},
        };
        point["fails"] = failedMetrics(point, spec);
        points.push_back(std::move(point));
      }
      gpuScene.destroy();
    }
  }
  progress.current = "done";
  if (options.progress) options.progress(progress);

  json byDistance = failsAt(points, "distance", {"variant", "triangle_size"});
  json bySize = failsAt(points, "triangle_size", {"variant", "distance"});
  json variantList = json::array();
  for (const auto& variant : variants) {
    json e = encodingJson(variant.encoding);
    e["variant"] = variant.name;
    variantList.push_back(e);
  }
  json result = {
      {"sweep", std::string(kPrecisionSweepName)},
      {"device", gpu::describe(ctx)},
      {"spec", spec.source},
      {"renderer", "visbuffer"},
      {"parameters", {"distance", "triangle_size", "variant"}},
      {"resolution", {v.width, v.height}},
      {"method",
       {{"reference", encodingJson(reference.encoding)},
        {"variants", variantList},
        {"formats", formats},
        {"barycentrics", barycentricSource},
        {"texture_size", spec.textureSize},
        {"levels", levels},
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
      {"points", points},
  };
  result["fails_at"] = byDistance.is_null() && bySize.is_null()
                           ? json(nullptr)
                           : json{{"distance", byDistance}, {"triangle_size", bySize}};
  result["plots"] = json::array({
      {{"title", "Image error against distance"},
       {"x", "distance"},
       {"x_log", true},
       {"y", "error.image.max_abs"},
       {"y_log", false},
       {"y_label", "max |difference| (8-bit levels)"},
       {"series", {"variant", "triangle_size"}},
       {"threshold", spec.imageThreshold}},
      {{"title", "Mip-level error against distance"},
       {"x", "distance"},
       {"x_log", true},
       {"y", "error.mip_level.max_abs"},
       {"y_log", false},
       {"y_label", "max |level - reference level| (levels)"},
       {"series", {"variant", "triangle_size"}},
       {"threshold", spec.mipThreshold}},
      {{"title", "uv error from the barycentrics against triangle size"},
       {"x", "triangle_size"},
       {"x_log", true},
       {"y", "error.uv_texels.max"},
       {"y_log", true},
       {"y_label", "max uv error (texels)"},
       {"series", {"variant", "distance"}},
       {"threshold", nullptr}},
  });
  return result;
}

}  // namespace tally::sweeps
