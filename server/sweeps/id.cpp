#include "sweeps/id.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>

#include "analysis/image.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/renderer.hpp"
#include "scenes/textures.hpp"
#include "shared.h"
#include "sweeps/fields.hpp"
#include "sweeps/skeleton.hpp"

namespace tally::sweeps {

using analysis::compareImages;
using analysis::ImageError;
namespace {

using nlohmann::json;

// The decode follows shared.h's documented layout; if that changes, so must
// the documentation of this sweep.
static_assert(IdLayout{}.triangleBits == shaders::kTriangleIdBits);
static_assert(kIdClear == shaders::kVisibilityClear);

constexpr double kPlaneDistance = 2.0;  // metres in front of the eye
constexpr float kFovDeg = 60.0f;
// The plane lies well inside near/far, fixed so the projection does not
// depend on the scene's bounds.
constexpr renderers::DepthRange kDepthRange = {0.5f, 8.0f};
constexpr double kEdgeMargin = 1e-3;  // pixels: a centre nearer an edge is ambiguous
constexpr size_t kExamples = 3;       // wrong pixels listed per point

using fields::fieldError;
using fields::show;

using fields::joined;

// An axis of distinct integers in [1, max].
Result<std::vector<uint64_t>> countList(const json& j, const std::string& field, uint64_t max) {
  return fields::distinctList<uint64_t>(
      j, field, kMaxIdSweepAxis, "integers", [&](const json& v, const std::string& f) -> Result<uint64_t> {
        if (!v.is_number_integer() || v.get<int64_t>() < 1 || uint64_t(v.get<int64_t>()) > max) {
          return fieldError(f, "must be an integer from 1 to " + std::to_string(max) + ", got " + show(v));
        }
        return uint64_t(v.get<int64_t>());
      });
}

}  // namespace

std::vector<std::string> idCapacityRenderers() { return {"visbuffer", "visbuffer-lean"}; }

bool idFits(uint64_t draws, uint64_t trianglesPerDraw) {
  // 9 bits of draw: draws 0..511. 23 bits of triangle, but the all-ones id
  // (draw 511, triangle 2^23 - 1) is the clear value: triangles 0..2^23 - 2.
  return draws <= (uint64_t{1} << 9) && trianglesPerDraw <= (uint64_t{1} << 23) - 1;
}

Result<IdSweepSpec> parseIdSweepSpec(const json& j, const std::vector<std::string>& knownRenderers) {
  if (auto e = fields::specObject(
          j, {"sweep", "renderers", "draws", "triangles_per_draw", "resolution", "threshold"}))
    return *e;
  IdSweepSpec spec;
  spec.source = j;

  if (j.contains("renderers")) {
    const auto& r = j["renderers"];
    const auto allowed = idCapacityRenderers();
    if (!r.is_array() || r.empty() || r.size() > allowed.size()) {
      return fieldError("renderers",
                        "must be an array of renderer names (of " + joined(allowed) + "), got " + show(r));
    }
    spec.renderers.clear();
    for (size_t i = 0; i < r.size(); ++i) {
      std::string f = "renderers[" + std::to_string(i) + "]";
      auto name = fields::rendererName(r[i], f, allowed, knownRenderers,
                                       "writes no visibility id, so it has no id capacity");
      if (!name) return name.failure();
      if (std::find(spec.renderers.begin(), spec.renderers.end(), *name) != spec.renderers.end()) {
        return fieldError(f, "'" + *name + "' listed twice");
      }
      spec.renderers.push_back(*name);
    }
  }

  if (!j.contains("draws")) return fieldError("draws", "required, e.g. [511, 512, 513]");
  auto draws = countList(j["draws"], "draws", kMaxIdSweepDraws);
  if (!draws) return draws.failure();
  spec.draws = *draws;

  if (!j.contains("triangles_per_draw"))
    return fieldError("triangles_per_draw", "required, e.g. [2, 8388607]");
  auto triangles = countList(j["triangles_per_draw"], "triangles_per_draw", kMaxIdSweepTriangles);
  if (!triangles) return triangles.failure();
  spec.trianglesPerDraw = *triangles;

  // Every point is built in full: the largest draws x the largest triangles must fit.
  const uint64_t maxDraws = *std::max_element(spec.draws.begin(), spec.draws.end());
  const uint64_t maxTriangles = *std::max_element(spec.trianglesPerDraw.begin(), spec.trianglesPerDraw.end());
  if (maxDraws * maxTriangles > kMaxIdSweepTriangles) {
    return fieldError("triangles_per_draw",
                      "draws " + std::to_string(maxDraws) + " x triangles_per_draw " +
                          std::to_string(maxTriangles) + " is " + std::to_string(maxDraws * maxTriangles) +
                          " triangles; a point builds at most " + std::to_string(kMaxIdSweepTriangles) +
                          " (sweep many draws and many triangles per draw in separate specs)");
  }

  if (j.contains("resolution")) {
    auto r = fields::resolution(j["resolution"], Resolution{kIdTileWidth, kIdTileHeight});
    if (!r) return r.failure();
    spec.resolution = *r;
  }

  if (j.contains("threshold")) {
    const auto& t = j["threshold"];
    if (!t.is_object() || t.size() != 1 || !t.contains("wrong_pixels")) {
      return fieldError("threshold", "must be {\"wrong_pixels\": n}, got " + show(t));
    }
    const auto& n = t["wrong_pixels"];
    if (!n.is_number_integer() || n.get<int64_t>() < 0) {
      return fieldError("threshold.wrong_pixels", "must be an integer >= 0, got " + show(n));
    }
    spec.wrongPixels = uint64_t(n.get<int64_t>());
  }
  return spec;
}

IdScene buildIdScene(uint64_t draws, uint64_t trianglesPerDraw, VkExtent2D extent) {
  IdScene out;
  out.extent = extent;
  out.camera.eye = glm::vec3(0.0f);
  out.camera.target = glm::vec3(0.0f, 0.0f, -1.0f);
  out.camera.fovDeg = kFovDeg;
  out.camera.label = "head-on";
  scenes::Scene& scene = out.scene;
  scene.name = "id-capacity";
  uint32_t material = scenes::addProceduralMaterial(scene, scenes::ProceduralMaterial::Plaster, 4);

  const uint32_t columns = extent.width / kIdTileWidth, rows = extent.height / kIdTileHeight;
  const uint64_t tiles = uint64_t{columns} * rows;
  out.tiledDraws = std::min(draws, tiles);
  out.visiblePerDraw = uint32_t(std::min<uint64_t>(kIdVisibleTriangles, trianglesPerDraw));
  // Pixel (x, y) (y down, top-left corner of the image at 0, 0) on the plane
  // z = -d: the perspective of a plane facing the eye is affine.
  const double tanHalf = std::tan(glm::radians(double(kFovDeg)) / 2.0);
  const double aspect = double(float(extent.width) / float(extent.height));
  auto onPlane = [&](double x, double y) {
    return glm::vec3(float((x / extent.width * 2.0 - 1.0) * tanHalf * aspect * kPlaneDistance),
                     float(-(y / extent.height * 2.0 - 1.0) * tanHalf * kPlaneDistance),
                     float(-kPlaneDistance));
  };
  const glm::vec3 normal(0.0f, 0.0f, 1.0f);
  // Which tile each draw gets: all draws when they fit, else draw 0 and the highest.
  auto tileOf = [&](uint64_t d) -> int64_t {
    if (draws <= tiles) return int64_t(d);
    if (d == 0) return 0;
    if (d >= draws - (tiles - 1)) return int64_t(d - (draws - tiles));
    return -1;
  };

  for (uint64_t d = 0; d < draws; ++d) {
    scenes::Mesh mesh;
    mesh.name = "draw " + std::to_string(d);
    mesh.material = material;
    int64_t tile = tileOf(d);
    const double ox = tile < 0 ? 0.0 : double(uint64_t(tile) % columns * kIdTileWidth);
    const double oy = tile < 0 ? 0.0 : double(uint64_t(tile) / columns * kIdTileHeight);
    auto vertex = [&](double x, double y) {
      glm::vec3 p = onPlane(x, y);
      mesh.vertices.push_back({p, normal, glm::vec4(1, 0, 0, 1), glm::vec2(float(x), float(y)) / 4.0f});
      return uint32_t(mesh.vertices.size() - 1);
    };
    // Vertex 0: the tile's corner, which every degenerate triangle repeats.
    vertex(ox, oy);
    const uint64_t visible = tile < 0 ? 0 : out.visiblePerDraw;
    mesh.indices.assign(size_t((trianglesPerDraw - visible) * 3), 0u);
    for (uint32_t i = 0; i < visible; ++i) {
      // Strip i / 2, split along its diagonal from a (top left) to c (bottom
      // right): even triangles take the bottom-left corner, odd the top-right.
      const double x0 = ox + 2.0 * (i / 2), x1 = x0 + 2.0, y0 = oy, y1 = oy + kIdTileHeight;
      uint32_t a = vertex(x0, y0), c = vertex(x1, y1);
      uint32_t third = i % 2 == 0 ? vertex(x0, y1) : vertex(x1, y0);
      mesh.indices.insert(mesh.indices.end(), {a, c, third});
    }
    scenes::updateBounds(mesh);
    scene.meshes.push_back(std::move(mesh));
  }
  scenes::updateBounds(scene);
  return out;
}

IdCoverage idCoverage(const scenes::Scene& scene, const scenes::Camera& camera, VkExtent2D extent) {
  const size_t pixels = size_t(extent.width) * extent.height;
  IdCoverage out;
  out.draw.assign(pixels, IdCoverage::kNone);
  out.triangle.assign(pixels, IdCoverage::kNone);
  out.ambiguous.assign(pixels, false);
  const glm::dmat4 view(scenes::viewMatrix(camera));
  const double tanHalf = std::tan(glm::radians(double(camera.fovDeg)) / 2.0);
  const double aspect = double(float(extent.width) / float(extent.height));
  // Pixel coordinates of a point (y down): the camera's perspective in double.
  auto project = [&](const glm::vec3& p) {
    glm::dvec4 v = view * glm::dvec4(glm::dvec3(p), 1.0);
    double ndcX = v.x / (-v.z * tanHalf * aspect), ndcY = -v.y / (-v.z * tanHalf);
    return glm::dvec2((ndcX + 1.0) / 2.0 * extent.width, (ndcY + 1.0) / 2.0 * extent.height);
  };
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const scenes::Mesh& mesh = scene.meshes[m];
    for (size_t t = 0; t * 3 + 2 < mesh.indices.size(); ++t) {
      const uint32_t* idx = &mesh.indices[t * 3];
      if (idx[0] == idx[1] && idx[1] == idx[2]) continue;  // one vertex thrice: no area
      glm::dvec2 p[3];
      for (int k = 0; k < 3; ++k) p[k] = project(mesh.vertices[idx[k]].position);
      double area = (p[1].x - p[0].x) * (p[2].y - p[0].y) - (p[1].y - p[0].y) * (p[2].x - p[0].x);
      if (area == 0.0) continue;
      double lo[2] = {std::min({p[0].x, p[1].x, p[2].x}), std::min({p[0].y, p[1].y, p[2].y})};
      double hi[2] = {std::max({p[0].x, p[1].x, p[2].x}), std::max({p[0].y, p[1].y, p[2].y})};
      int64_t x0 = std::max<int64_t>(0, int64_t(std::floor(lo[0] - 1))),
              y0 = std::max<int64_t>(0, int64_t(std::floor(lo[1] - 1)));
      int64_t x1 = std::min<int64_t>(extent.width - 1, int64_t(std::ceil(hi[0] + 1)));
      int64_t y1 = std::min<int64_t>(extent.height - 1, int64_t(std::ceil(hi[1] + 1)));
      for (int64_t y = y0; y <= y1; ++y) {
        for (int64_t x = x0; x <= x1; ++x) {
          glm::dvec2 c(double(x) + 0.5, double(y) + 0.5);
          // Signed distance of the centre from each edge, positive inside.
          bool inside = true, near = false;
          for (int k = 0; k < 3; ++k) {
            glm::dvec2 a = p[k], b = p[(k + 1) % 3];
            double cross = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
            double distance = (area > 0 ? cross : -cross) / glm::length(b - a);
            if (distance < -kEdgeMargin) inside = false;
            if (std::abs(distance) <= kEdgeMargin) near = true;
          }
          if (!inside) continue;
          size_t i = size_t(y) * extent.width + size_t(x);
          if (near || out.draw[i] != IdCoverage::kNone) out.ambiguous[i] = true;
          out.draw[i] = uint32_t(m);
          out.triangle[i] = uint32_t(t);
        }
      }
    }
  }
  return out;
}

json IdCheck::toJson() const {
  return {{"wrong_pixels", wrong},
          {"missing_pixels", missing},
          {"checked_pixels", checked},
          {"covered_pixels", covered},
          {"ambiguous_pixels", ambiguous},
          {"highest_right", {{"draw", highestDraw}, {"triangle", highestTriangle}}},
          {"examples", examples}};
}

IdCheck checkIds(std::span<const uint32_t> ids, const IdCoverage& truth, VkExtent2D extent,
                 const IdLayout& layout) {
  IdCheck out;
  for (size_t i = 0; i < ids.size() && i < truth.draw.size(); ++i) {
    if (truth.ambiguous[i]) {
      ++out.ambiguous;
      continue;
    }
    ++out.checked;
    const uint32_t id = ids[i];
    const bool covered = truth.draw[i] != IdCoverage::kNone;
    if (covered) ++out.covered;
    bool right = id == kIdClear ? !covered
                                : covered && layout.draw(id) == truth.draw[i] &&
                                      layout.triangle(id) == truth.triangle[i];
    if (right && covered) {
      out.highestDraw = std::max(out.highestDraw, truth.draw[i]);
      out.highestTriangle = std::max(out.highestTriangle, truth.triangle[i]);
    }
    if (right) continue;
    ++out.wrong;
    if (covered && id == kIdClear) ++out.missing;
    if (out.examples.size() < kExamples) {
      json e = {{"pixel", {i % extent.width, i / extent.width}}, {"id", id}};
      e["decoded"] =
          id == kIdClear ? json(nullptr) : json{{"draw", layout.draw(id)}, {"triangle", layout.triangle(id)}};
      e["expected"] =
          covered ? json{{"draw", truth.draw[i]}, {"triangle", truth.triangle[i]}} : json(nullptr);
      out.examples.push_back(e);
    }
  }
  return out;
}

std::vector<uint32_t> idsOf(std::span<const uint8_t> targetBytes, uint64_t pixels) {
  if (pixels == 0 || (targetBytes.size() != pixels * 4 && targetBytes.size() != pixels * 8)) return {};
  const size_t stride = targetBytes.size() / pixels;
  std::vector<uint32_t> out(pixels);
  for (size_t i = 0; i < pixels; ++i)
    std::memcpy(&out[i], &targetBytes[i * stride], 4);  // little-endian hosts
  return out;
}

namespace {

// n values reduced modulo m fall into residue classes: `residues` classes hold
// `size` values each (at most two sizes: n / m + 1 and n / m).
struct ResidueClass {
  uint64_t size = 0, residues = 0;
};
std::vector<ResidueClass> residueClasses(uint64_t n, uint64_t m) {
  std::vector<ResidueClass> out;
  if (n % m) out.push_back({n / m + 1, n % m});
  if (n / m) out.push_back({n / m, m - n % m});
  return out;
}
uint64_t classSize(uint64_t n, uint64_t m, uint64_t residue) { return n / m + (residue < n % m ? 1 : 0); }

}  // namespace

json wouldAlias(uint64_t draws, uint64_t trianglesPerDraw) {
  const uint64_t drawIds = uint64_t{1} << shaders::kDrawIdBits,
                 triangleIds = uint64_t{1} << shaders::kTriangleIdBits;
  uint64_t sharedDraws = 0, sharedTriangles = 0, sharedIds = 0;
  for (const auto& c : residueClasses(draws, drawIds)) sharedDraws += c.size > 1 ? c.size * c.residues : 0;
  for (const auto& c : residueClasses(trianglesPerDraw, triangleIds))
    sharedTriangles += c.size > 1 ? c.size * c.residues : 0;
  for (const auto& a : residueClasses(draws, drawIds)) {
    for (const auto& b : residueClasses(trianglesPerDraw, triangleIds)) {
      if (a.size * b.size > 1) sharedIds += a.size * b.size * a.residues * b.residues;
    }
  }
  // The clear value: draw residue 511 with triangle residue 2^23 - 1.
  const uint64_t clear =
      classSize(draws, drawIds, drawIds - 1) * classSize(trianglesPerDraw, triangleIds, triangleIds - 1);
  if (clear == 1) ++sharedIds;  // alone in its id, but that id reads as "nothing drawn"
  const uint64_t lastDraw = draws - 1, lastTriangle = trianglesPerDraw - 1;
  const uint32_t packed =
      uint32_t(((lastDraw % drawIds) << shaders::kTriangleIdBits) | (lastTriangle % triangleIds));
  return {{"draws_sharing_a_draw_id", sharedDraws},
          {"triangles_sharing_a_triangle_id_per_draw", sharedTriangles},
          {"triangles_sharing_an_id", sharedIds},
          {"triangles_read_as_clear", clear},
          {"last_triangle",
           {{"draw", lastDraw},
            {"triangle", lastTriangle},
            {"id", packed},
            {"decoded_draw", lastDraw % drawIds},
            {"decoded_triangle", lastTriangle % triangleIds},
            {"clear", packed == kIdClear}}}};
}

namespace {

bool mentions(const std::string& text, uint64_t number) {
  // As a whole number: "5120" does not mention 512.
  const std::string n = std::to_string(number);
  for (size_t at = text.find(n); at != std::string::npos; at = text.find(n, at + 1)) {
    bool before = at > 0 && std::isdigit(static_cast<unsigned char>(text[at - 1]));
    bool after = at + n.size() < text.size() && std::isdigit(static_cast<unsigned char>(text[at + n.size()]));
    if (!before && !after) return true;
  }
  return false;
}

json imageErrorJson(const ImageError& e) {
  return {{"against", "forward"},
          {"psnr", std::isinf(e.psnr) ? json(nullptr) : json(e.psnr)},
          {"identical", std::isinf(e.psnr)},
          {"max_abs", e.maxAbs},
          {"mean_abs", e.meanAbs}};
}

// One scene of the sweep, which every renderer's point draws.
struct IdScenePoint {
  uint64_t draws = 0, triangles = 0;
  std::string name;  // "draws 512 triangles_per_draw 4"
  const IdScene& built;
  const IdCoverage& truth;
  const renderers::GpuScene& gpuScene;
  renderers::RendererOptions options;
  std::vector<uint8_t> reference = {};  // the forward image, made once, when a renderer draws
};

Result<bool> forwardImage(gpu::Context& ctx, IdScenePoint& at) {
  if (!at.reference.empty()) return true;
  auto made = renderers::makeRenderer("forward");
  if (!made) return made.failure();
  auto ok = (*made)->setup(ctx, at.gpuScene, at.options);
  if (!ok) return ok.failure();
  (*made)->renderFrame(at.built.camera);
  at.reference = (*made)->finalImage();
  (*made)->destroy();
  return true;
}

// The point of the renderer `name` on the scene: refused, with what the
// refusal names and what packing anyway would alias, or rendered, with its
// ids checked against the truth and its image against forward's.
Result<json> idPoint(gpu::Context& ctx, IdScenePoint& at, const std::string& name, const IdSweepSpec& spec) {
  const std::string where = name + " " + at.name;
  const uint64_t draws = at.draws, triangles = at.triangles;
  const bool fits = idFits(draws, triangles);
  json point = {{"renderer", name},
                {"draws", draws},
                {"triangles_per_draw", triangles},
                {"total_triangles", draws * triangles},
                {"expected", fits ? "rendered" : "refused"},
                {"tiled_draws", at.built.tiledDraws},
                {"visible_triangles_per_draw", at.built.visiblePerDraw}};
  auto made = renderers::makeRenderer(name);
  if (!made) return makeError(where + ": " + made.error());
  auto ok = (*made)->setup(ctx, at.gpuScene, at.options);
  if (!ok) {
    // The reason must name the limit crossed and the scene's count.
    const bool drawsOver = draws > shaders::kMaxDraws;
    const uint64_t limit = drawsOver ? shaders::kMaxDraws : shaders::kTriangleIdMask;
    const uint64_t count = drawsOver ? draws : triangles;
    point["status"] = "refused";
    point["refused"] = 1;
    point["error"] = IdCheck{}.toJson();
    point["refusal"] = {{"message", ok.error()},
                        {"names_limit", mentions(ok.error(), limit)},
                        {"names_count", mentions(ok.error(), count)}};
    point["would_alias"] = wouldAlias(draws, triangles);
  } else {
    const VkExtent2D extent = at.options.extent;
    const uint64_t pixels = uint64_t{extent.width} * extent.height;
    (*made)->renderFrame(at.built.camera);
    std::vector<uint8_t> bytes = (*made)->targetBytes("visibility.id");
    std::vector<uint8_t> image = (*made)->finalImage();
    json notes = (*made)->notes();
    (*made)->destroy();
    std::vector<uint32_t> ids = idsOf(bytes, pixels);
    if (ids.empty()) {
      return makeError(where + ": the visibility.id target could not be read back (" +
                       std::to_string(bytes.size()) + " bytes for " + std::to_string(pixels) + " pixels)");
    }
    IdCheck check = checkIds(ids, at.truth, extent);
    point["status"] = "rendered";
    point["refused"] = 0;
    point["error"] = check.toJson();
    point["notes"] = notes;
    if (auto ref = forwardImage(ctx, at); !ref) return makeError(at.name + " forward: " + ref.error());
    auto imageError = compareImages(image, at.reference, extent.width, extent.height);
    if (!imageError) return makeError(where + ": " + imageError.error());
    point["image_error"] = imageErrorJson(*imageError);
  }
  point["fails"] =
      point["status"] == "refused" || point["error"]["wrong_pixels"].get<uint64_t>() > spec.wrongPixels;
  return point;
}

// The result around the points: the id's capacity, the method, where the
// points start to fail along each axis, and the charts.
json idReport(const IdSweepSpec& spec, const json& points) {
  // Per group of points that differ only in one axis, the smallest value of
  // it at which a point fails.
  auto fails = [](const json& p) { return p["fails"].get<bool>(); };
  const json threshold = spec.wrongPixels;
  return {
      {"renderers", spec.renderers},
      {"parameters", {"draws", "triangles_per_draw"}},
      {"resolution", {spec.resolution.width, spec.resolution.height}},
      {"capacity",
       {{"draws", shaders::kMaxDraws},
        {"triangles_per_draw", shaders::kTriangleIdMask},
        {"draw_id_bits", shaders::kDrawIdBits},
        {"triangle_id_bits", shaders::kTriangleIdBits},
        {"clear_id", shaders::kVisibilityClear}}},
      {"method",
       {{"id", "draw << 23 | triangle (shared.h packVisibilityId), read back from visibility.id"},
        {"truth", "each pixel centre against the scene's triangles projected on the CPU (double)"},
        {"scene",
         "per draw, all but the last visible_triangles_per_draw triangles degenerate; those tile a plane "
         "facing the eye, one tile of 4 x 3 pixels per draw (draw 0 and the highest draws when the "
         "resolution holds fewer tiles than draws)"},
        {"tile_pixels", {kIdTileWidth, kIdTileHeight}},
        {"plane_distance", kPlaneDistance},
        {"fov_deg", kFovDeg}}},
      {"threshold", {{"wrong_pixels", spec.wrongPixels}}},
      {"plots",
       {plot("Wrong pixels against draws", "draws", "error.wrong_pixels", false, "wrong pixels",
             {"renderer", "triangles_per_draw"}, threshold),
        plot("Refused against draws", "draws", "refused", false, "refused (1) or rendered (0)",
             {"renderer", "triangles_per_draw"}, nullptr),
        plot("Wrong pixels against triangles per draw", "triangles_per_draw", "error.wrong_pixels", false,
             "wrong pixels", {"renderer", "draws"}, threshold),
        plot("Refused against triangles per draw", "triangles_per_draw", "refused", false,
             "refused (1) or rendered (0)", {"renderer", "draws"}, nullptr)}},
      {"fails_at",
       failsAtByAxis({{"draws", smallestFailing(points, "draws", {"renderer", "triangles_per_draw"}, fails)},
                      {"triangles_per_draw",
                       smallestFailing(points, "triangles_per_draw", {"renderer", "draws"}, fails)}})},
  };
}

}  // namespace

Result<json> runIdSweep(gpu::Context& ctx, const IdSweepSpec& spec, const SweepOptions& options) {
  const VkExtent2D extent = {spec.resolution.width, spec.resolution.height};
  SweepRun run(ctx, options, spec.renderers.size() * spec.draws.size() * spec.trianglesPerDraw.size());
  for (uint64_t triangles : spec.trianglesPerDraw) {
    for (uint64_t draws : spec.draws) {
      const std::string name =
          "draws " + std::to_string(draws) + " triangles_per_draw " + std::to_string(triangles);
      IdScene built = buildIdScene(draws, triangles, extent);
      const IdCoverage truth = idCoverage(built.scene, built.camera, extent);
      auto ran = run.withScene(built.scene, name, [&](const renderers::GpuScene& gpuScene) -> Result<bool> {
        built.scene.meshes.clear();  // the index data lives on in gpuScene: free the CPU copy
        built.scene.meshes.shrink_to_fit();
        IdScenePoint at{draws,
                        triangles,
                        name,
                        built,
                        truth,
                        gpuScene,
                        renderers::RendererOptions{extent, false, spirv::Mode{}, 0, kDepthRange}};
        for (const auto& renderer : spec.renderers) {
          run.next(renderer + " " + name);
          auto point = idPoint(ctx, at, renderer, spec);
          if (!point) return point.failure();
          run.points.push_back(std::move(*point));
        }
        return true;
      });
      if (!ran) return ran.failure();
    }
  }
  json report = idReport(spec, run.points);
  return run.finish(kIdSweepName, spec.source, std::move(report));
}

}  // namespace tally::sweeps
