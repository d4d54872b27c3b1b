#include "scenes/heatmap.hpp"

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <limits>
#include <set>

#include "common/json_fields.hpp"

namespace tally::scenes {
namespace {

using nlohmann::json;

constexpr size_t kMaxColumnHits = 256;  // surfaces followed down one column
// Back faces an eye may see among its 26 rays whatever else they hit (see
// eyeClear).
constexpr int kMaxBackFaces = 2;

using json_fields::fieldError;
using json_fields::num;
using json_fields::show;

// A finite number in [low, high] (above low where `openLow`).
Result<float> numberField(const json& j, const std::string& field, float low, float high, bool openLow = false) {
  auto v = json_fields::number(j, field, low, high, openLow);
  if (!v) return v.failure();
  return float(*v);
}

std::vector<glm::vec3> faceNormals(const Scene& scene) {
  std::vector<glm::vec3> out;
  out.reserve(scene.triangleCount());
  for (const Mesh& m : scene.meshes) {
    for (size_t i = 0; i + 2 < m.indices.size(); i += 3) {
      const glm::vec3& a = m.vertices[m.indices[i]].position;
      glm::vec3 n = glm::cross(m.vertices[m.indices[i + 1]].position - a, m.vertices[m.indices[i + 2]].position - a);
      float len = glm::length(n);
      out.push_back(len > 0.0f ? n / len : glm::vec3(0.0f));
    }
  }
  return out;
}

struct ColumnHit {
  float y;
  float up;  // |normal.y|: 1 for a level surface
  bool backFace;
};

// Every surface straight down from `top` at (x, z), highest first.
std::vector<ColumnHit> columnHits(const Bvh& bvh, const std::vector<glm::vec3>& normals, float x, float z, float top,
                                  float bottom, float step) {
  std::vector<ColumnHit> hits;
  float y = top;
  while (hits.size() < kMaxColumnHits && y > bottom) {
    Ray ray{{x, y, z}, {0.0f, -1.0f, 0.0f}, y - bottom};
    std::optional<Hit> h = bvh.closestHit(ray);
    if (!h) break;
    float at = y - h->t;
    float up = h->triangle < normals.size() ? std::abs(normals[h->triangle].y) : 0.0f;
    hits.push_back({at, up, h->backFace});
    y = at - step;  // past this surface (and any coplanar twin)
  }
  return hits;
}

// No surface closer than `clearance` in 26 directions (cube corners, edges
// and faces), and no more than half of the rays that hit (and at least
// kMaxBackFaces) seeing a back face: inside a closed object every ray sees
// one, while a ray that grazes an edge of a nearby box may see one or two.
bool eyeClear(const Bvh& bvh, const glm::vec3& eye, float clearance) {
  int backFaces = 0, hits = 0;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z) {
        if (x == 0 && y == 0 && z == 0) continue;
        std::optional<Hit> h = bvh.closestHit({eye, glm::normalize(glm::vec3(x, y, z))});
        if (!h) continue;
        if (h->t < clearance) return false;
        ++hits;
        if (h->backFace) ++backFaces;
      }
  return backFaces <= std::max(kMaxBackFaces, hits / 2);
}

glm::vec3 yawDirection(float yawDeg, float pitchDeg) {
  float yaw = glm::radians(yawDeg), pitch = glm::radians(pitchDeg);
  // Yaw 0 looks down +X, 90 down +Z (as scenes::autoCameras).
  return glm::vec3(std::cos(pitch) * std::cos(yaw), std::sin(pitch), std::cos(pitch) * std::sin(yaw));
}

float round3(float v) { return std::round(v * 1000.0f) / 1000.0f; }  // metres to the millimetre in labels and JSON

// The floor grid over the region (the scene's x-z bounds by default): its
// corners and cell size.
struct FloorGrid {
  float x0, z0, x1, z1;
  float dx, dz;
  uint32_t columns, rows;

  size_t cells() const { return size_t(columns) * rows; }
  glm::vec2 centre(size_t k) const {
    return glm::vec2(x0 + (float(k % columns) + 0.5f) * dx, z0 + (float(k / columns) + 0.5f) * dz);
  }
};

FloorGrid gridOver(const Scene& scene, const HeatmapSpec& spec) {
  const Bounds& b = scene.bounds;
  std::array<float, 4> region = spec.region.value_or(std::array<float, 4>{b.min.x, b.min.z, b.max.x, b.max.z});
  const float x0 = region[0], z0 = region[1], x1 = region[2], z1 = region[3];
  return {x0, z0, x1, z1, (x1 - x0) / float(spec.columns), (z1 - z0) / float(spec.rows), spec.columns, spec.rows};
}

// Per cell: its floor, the floors it could have (lowest first) and why it has none.
struct CellFloors {
  std::vector<std::optional<float>> floor;
  std::vector<std::vector<float>> candidates;
  std::vector<std::string> reason;
};

// The lowest valid floor of each cell, or why there is none; and every
// level surface with headroom (the candidates), lowest first.
CellFloors lowestFloors(const Scene& scene, const Bvh& bvh, const HeatmapSpec& spec, const FloorGrid& grid) {
  const Bounds& b = scene.bounds;
  const float diagonal = std::max(b.diagonal(), 1e-3f);
  const float top = b.max.y + 0.01f * diagonal + 1.0f, bottom = b.min.y - 0.01f * diagonal - 1.0f;
  const float step = 1e-5f * diagonal;
  const float minUp = std::cos(glm::radians(spec.maxSlopeDeg));
  const std::vector<glm::vec3> normals = faceNormals(scene);

  const size_t cells = grid.cells();
  CellFloors out{std::vector<std::optional<float>>(cells), std::vector<std::vector<float>>(cells),
                 std::vector<std::string>(cells, kNoSurface)};
  for (size_t k = 0; k < cells && !b.empty(); ++k) {
    const glm::vec2 at = grid.centre(k);
    std::vector<ColumnHit> hits = columnHits(bvh, normals, at.x, at.y, top, bottom, step);
    bool seenLevel = false;
    for (size_t i = hits.size(); i-- > 0;) {  // lowest first
      const ColumnHit& h = hits[i];
      if (h.up < minUp) continue;
      seenLevel = true;
      const float above = i == 0 ? std::numeric_limits<float>::infinity() : hits[i - 1].y - h.y;
      if (above >= spec.headroom) out.candidates[k].push_back(h.y);
    }
    for (float y : out.candidates[k]) {
      if (eyeClear(bvh, {at.x, y + spec.eyeHeight, at.y}, spec.clearance)) {
        out.floor[k] = y;
        break;
      }
    }
    if (!out.floor[k])
      out.reason[k] = !seenLevel ? kNoSurface : out.candidates[k].empty() ? kNoHeadroom : kEyeBlocked;
  }
  return out;
}

// The ground level: the median of the cells' lowest floors (the lower
// middle one for an even count). A cell keeps the lowest valid floor within
// max_rise of it; one without is on another level only (an upper storey
// seen through a wall cell, the top of a pillar) and is empty. A basement
// under a ground-level floor does not hide it.
std::optional<float> keepGroundLevel(CellFloors& cells, const Bvh& bvh, const HeatmapSpec& spec,
                                     const FloorGrid& grid) {
  std::vector<float> heights;
  for (const auto& f : cells.floor)
    if (f) heights.push_back(*f);
  if (heights.empty()) return std::nullopt;
  std::sort(heights.begin(), heights.end());
  const float ground = heights[(heights.size() - 1) / 2];
  for (size_t k = 0; k < grid.cells(); ++k) {
    if (!cells.floor[k] || std::abs(*cells.floor[k] - ground) <= spec.maxRise) continue;
    cells.floor[k].reset();
    cells.reason[k] = kOffLevel;
    const glm::vec2 at = grid.centre(k);
    for (float y : cells.candidates[k]) {
      if (std::abs(y - ground) <= spec.maxRise && eyeClear(bvh, {at.x, y + spec.eyeHeight, at.y}, spec.clearance)) {
        cells.floor[k] = y;
        break;
      }
    }
  }
  return ground;
}

// The poses of the cells with a floor (row-major, yaws innermost), and the
// layout's grids of floor heights and of why a cell is empty.
struct FloorPoses {
  std::vector<HeatmapPose> poses;
  json floorGrid = json::array(), emptyGrid = json::array(), yawsDeg = json::array();
  json emptyCounts = {{kNoSurface, 0}, {kNoHeadroom, 0}, {kEyeBlocked, 0}, {kOffLevel, 0}};
  size_t withFloor = 0;
};

FloorPoses floorPoses(const CellFloors& cells, const HeatmapSpec& spec, const FloorGrid& grid) {
  FloorPoses out;
  std::vector<float> yawAngles;
  for (uint32_t y = 0; y < spec.yaws; ++y) {
    yawAngles.push_back(360.0f * float(y) / float(spec.yaws));
    out.yawsDeg.push_back(yawAngles.back());
  }
  for (uint32_t r = 0; r < spec.rows; ++r) {
    json floorRow = json::array(), emptyRow = json::array();
    for (uint32_t c = 0; c < spec.columns; ++c) {
      const size_t k = size_t(r) * spec.columns + c;
      if (!cells.floor[k]) {
        floorRow.push_back(nullptr);
        emptyRow.push_back(cells.reason[k]);
        out.emptyCounts[cells.reason[k]] = out.emptyCounts[cells.reason[k]].get<int>() + 1;
        continue;
      }
      ++out.withFloor;
      floorRow.push_back(round3(*cells.floor[k]));
      emptyRow.push_back(nullptr);
      const glm::vec3 eye(grid.x0 + (float(c) + 0.5f) * grid.dx, *cells.floor[k] + spec.eyeHeight,
                          grid.z0 + (float(r) + 0.5f) * grid.dz);
      for (uint32_t y = 0; y < spec.yaws; ++y) {
        HeatmapPose p;
        p.column = c;
        p.row = r;
        p.yaw = y;
        p.camera.eye = eye;
        p.camera.target = eye + yawDirection(yawAngles[y], spec.pitchDeg) * 10.0f;
        p.camera.fovDeg = spec.fovDeg;
        char label[96];
        std::snprintf(label, sizeof label, "heatmap cell %u,%u yaw %g", c, r, double(yawAngles[y]));
        p.camera.label = label;
        out.poses.push_back(std::move(p));
      }
    }
    out.floorGrid.push_back(std::move(floorRow));
    out.emptyGrid.push_back(std::move(emptyRow));
  }
  return out;
}

HeatmapPlacement placeFloor(const Scene& scene, const Bvh& bvh, const HeatmapSpec& spec) {
  const FloorGrid grid = gridOver(scene, spec);
  const float x0 = grid.x0, z0 = grid.z0, x1 = grid.x1, z1 = grid.z1;
  CellFloors cells = lowestFloors(scene, bvh, spec, grid);
  const std::optional<float> ground = keepGroundLevel(cells, bvh, spec, grid);
  FloorPoses placed = floorPoses(cells, spec, grid);

  HeatmapPlacement out;
  out.poses = std::move(placed.poses);
  // The top-down image spans the grid; pixels are square.
  const float extent = std::max(x1 - x0, z1 - z0);
  const float pixel = extent / float(kTopDownMaxSide);
  const uint32_t width = std::max(1u, uint32_t(std::lround((x1 - x0) / pixel)));
  const uint32_t height = std::max(1u, uint32_t(std::lround((z1 - z0) / pixel)));
  out.layout = {{"layout", "floor"},
                {"columns", spec.columns},
                {"rows", spec.rows},
                {"axes", {"x", "z"}},
                {"origin", {x0, z0}},
                {"cell_size", {grid.dx, grid.dz}},
                {"up", "y"},
                {"eye_height", spec.eyeHeight},
                {"yaws_deg", placed.yawsDeg},
                {"pitch_deg", spec.pitchDeg},
                {"fov_deg", spec.fovDeg},
                {"headroom", spec.headroom},
                {"clearance", spec.clearance},
                {"max_slope_deg", spec.maxSlopeDeg},
                {"max_rise", spec.maxRise},
                {"ground", ground ? json(round3(*ground)) : json(nullptr)},
                {"cut_height", ground ? json(round3(*ground + spec.eyeHeight)) : json(nullptr)},
                {"floor", std::move(placed.floorGrid)},
                {"empty", std::move(placed.emptyGrid)},
                {"cells_with_floor", placed.withFloor},
                {"empty_counts", placed.emptyCounts},
                {"poses", out.poses.size()},
                {"image", {{"x0", x0}, {"z0", z0}, {"x1", x1}, {"z1", z1}, {"width", width}, {"height", height}}}};
  return out;
}

HeatmapPlacement placeSphere(const Scene& scene, const HeatmapSpec& spec) {
  const glm::vec3 center = scene.bounds.empty() ? glm::vec3(0.0f) : scene.bounds.center();
  const float radius = std::max(0.5f * scene.bounds.diagonal(), 1e-3f);
  const float distance = spec.distance * radius;
  HeatmapPlacement out;
  json latitudes = json::array(), longitudes = json::array();
  for (uint32_t r = 0; r < spec.rings; ++r) latitudes.push_back(90.0f - (float(r) + 0.5f) * 180.0f / float(spec.rings));
  for (uint32_t s = 0; s < spec.segments; ++s)
    longitudes.push_back(-180.0f + (float(s) + 0.5f) * 360.0f / float(spec.segments));
  for (uint32_t r = 0; r < spec.rings; ++r) {
    const float lat = glm::radians(latitudes[r].get<float>());
    for (uint32_t s = 0; s < spec.segments; ++s) {
      const float lon = glm::radians(longitudes[s].get<float>());
      HeatmapPose p;
      p.column = s;
      p.row = r;
      const glm::vec3 dir(std::cos(lat) * std::cos(lon), std::sin(lat), std::cos(lat) * std::sin(lon));
      p.camera.eye = center + dir * distance;
      p.camera.target = center;
      p.camera.fovDeg = spec.fovDeg;
      char label[96];
      std::snprintf(label, sizeof label, "heatmap ring %u segment %u (lat %g, lon %g)", r, s,
                    double(latitudes[r].get<float>()), double(longitudes[s].get<float>()));
      p.camera.label = label;
      out.poses.push_back(std::move(p));
    }
  }
  out.layout = {{"layout", "sphere"},
                {"columns", spec.segments},
                {"rows", spec.rings},
                {"axes", {"longitude", "latitude"}},
                {"center", {center.x, center.y, center.z}},
                {"radius", radius},
                {"distance", distance},
                {"distance_radii", spec.distance},
                {"latitudes_deg", latitudes},
                {"longitudes_deg", longitudes},
                {"yaws_deg", {0.0f}},
                {"fov_deg", spec.fovDeg},
                {"poses", out.poses.size()}};
  return out;
}

}  // namespace

Result<HeatmapSpec> parseHeatmapSpec(const json& j) {
  if (!j.is_object()) return fieldError("heatmap", "must be an object with \"layout\": \"floor\" or \"sphere\", got " + show(j));
  HeatmapSpec spec;
  if (!j.contains("layout")) return fieldError("heatmap.layout", "required: \"floor\" or \"sphere\"");
  auto layout = json_fields::oneOf(j["layout"], "heatmap.layout", {"floor", "sphere"});
  if (!layout) return layout.failure();
  spec.layout = *layout == "floor" ? HeatmapSpec::Layout::Floor : HeatmapSpec::Layout::Sphere;
  const bool floor = spec.layout == HeatmapSpec::Layout::Floor;
  // Listed in alphabetical order, as the message always did.
  static const std::vector<std::string> kFloorKeys = {"cells",     "clearance", "eye_height", "fov_deg",
                                                      "headroom",  "layout",    "max_rise",   "max_slope_deg",
                                                      "pitch_deg", "region",    "yaws"};
  static const std::vector<std::string> kSphereKeys = {"distance", "fov_deg", "layout", "rings", "segments"};
  if (auto e = json_fields::unknownKey(
          j, "heatmap", floor ? kFloorKeys : kSphereKeys,
          std::string("unknown field for the ") + (floor ? "floor" : "sphere") + " layout")) {
    return *e;
  }
  if (j.contains("fov_deg")) {
    auto v = numberField(j["fov_deg"], "heatmap.fov_deg", 1.0f, 179.0f);
    if (!v) return v.failure();
    spec.fovDeg = *v;
  }
  if (!floor) {
    if (j.contains("rings")) {
      auto v = json_fields::count(j["rings"], "heatmap.rings", 1, kMaxHeatmapRings);
      if (!v) return v.failure();
      spec.rings = *v;
    }
    if (j.contains("segments")) {
      auto v = json_fields::count(j["segments"], "heatmap.segments", 1, kMaxHeatmapSegments);
      if (!v) return v.failure();
      spec.segments = *v;
    }
    if (j.contains("distance")) {
      // In bounding-sphere radii: above 1 the eyes are outside every triangle.
      auto v = numberField(j["distance"], "heatmap.distance", 0.0f, 100.0f, true);
      if (!v) return v.failure();
      spec.distance = *v;
    }
    return spec;
  }
  if (j.contains("cells")) {
    const json& cells = j["cells"];
    if (!cells.is_array() || cells.size() != 2) {
      return fieldError("heatmap.cells", "must be [columns along x, rows along z], got " + show(cells));
    }
    auto c = json_fields::count(cells[0], "heatmap.cells[0]", 1, kMaxHeatmapCells);
    if (!c) return c.failure();
    auto r = json_fields::count(cells[1], "heatmap.cells[1]", 1, kMaxHeatmapCells);
    if (!r) return r.failure();
    spec.columns = *c;
    spec.rows = *r;
  }
  if (j.contains("yaws")) {
    auto v = json_fields::count(j["yaws"], "heatmap.yaws", 1, kMaxHeatmapYaws);
    if (!v) return v.failure();
    spec.yaws = *v;
  }
  struct Number {
    const char* key;
    float* into;
    float low, high;
    bool openLow;
  };
  for (const Number& n : {Number{"eye_height", &spec.eyeHeight, 0.0f, 1000.0f, true},
                          Number{"pitch_deg", &spec.pitchDeg, -89.0f, 89.0f, false},
                          Number{"headroom", &spec.headroom, 0.0f, 1000.0f, true},
                          Number{"clearance", &spec.clearance, 0.0f, 100.0f, true},
                          Number{"max_slope_deg", &spec.maxSlopeDeg, 0.0f, 89.0f, false},
                          Number{"max_rise", &spec.maxRise, 0.0f, 10000.0f, false}}) {
    if (!j.contains(n.key)) continue;
    auto v = numberField(j[n.key], std::string("heatmap.") + n.key, n.low, n.high, n.openLow);
    if (!v) return v.failure();
    *n.into = *v;
  }
  if (spec.headroom <= spec.eyeHeight) {
    return fieldError("heatmap.headroom", "must be above eye_height (" + num(spec.eyeHeight) + "), got " +
                                              num(spec.headroom) + ": the eye must fit under what is above the floor");
  }
  if (j.contains("region")) {
    const json& region = j["region"];
    if (!region.is_array() || region.size() != 2) {
      return fieldError("heatmap.region", "must be [[x0, z0], [x1, z1]], got " + show(region));
    }
    std::array<float, 4> r{};
    for (size_t i = 0; i < 2; ++i) {
      const std::string at = "heatmap.region[" + std::to_string(i) + "]";
      if (!region[i].is_array() || region[i].size() != 2) return fieldError(at, "must be [x, z], got " + show(region[i]));
      for (size_t k = 0; k < 2; ++k) {
        auto v = numberField(region[i][k], at + "[" + std::to_string(k) + "]", -1e6f, 1e6f);
        if (!v) return v.failure();
        r[i * 2 + k] = *v;
      }
    }
    if (!(r[0] < r[2])) return fieldError("heatmap.region[1][0]", "must be above region[0][0] (x1 > x0)");
    if (!(r[1] < r[3])) return fieldError("heatmap.region[1][1]", "must be above region[0][1] (z1 > z0)");
    spec.region = r;
  }
  if (spec.maxPoses() > kMaxHeatmapPoses) {
    return fieldError("heatmap", "cells x yaws is " + std::to_string(spec.maxPoses()) + " poses, more than the limit of " +
                                     std::to_string(kMaxHeatmapPoses));
  }
  return spec;
}

HeatmapPlacement placeHeatmap(const Scene& scene, const Bvh& bvh, const HeatmapSpec& spec) {
  return spec.layout == HeatmapSpec::Layout::Floor ? placeFloor(scene, bvh, spec) : placeSphere(scene, spec);
}

HeatmapPlacement placeHeatmap(const Scene& scene, const HeatmapSpec& spec) {
  if (spec.layout == HeatmapSpec::Layout::Sphere) return placeSphere(scene, spec);
  return placeFloor(scene, Bvh::build(scene), spec);
}

json poseJson(const HeatmapPose& pose, const HeatmapSpec& spec) {
  json j = {{"column", pose.column}, {"row", pose.row}, {"yaw", pose.yaw}};
  if (spec.layout == HeatmapSpec::Layout::Floor) j["yaw_deg"] = 360.0f * float(pose.yaw) / float(spec.yaws);
  return j;
}

Result<TopDownImage> renderTopDown(const Scene& scene, const Bvh& bvh, const json& layout) {
  if (!layout.is_object() || layout.value("layout", "") != "floor") return makeError("not a floor layout");
  const json* image = layout.contains("image") ? &layout["image"] : nullptr;
  auto number = [&](const json* o, const char* key) -> std::optional<float> {
    if (!o || !o->is_object() || !o->contains(key) || !(*o)[key].is_number()) return std::nullopt;
    return (*o)[key].get<float>();
  };
  auto x0 = number(image, "x0"), z0 = number(image, "z0"), x1 = number(image, "x1"), z1 = number(image, "z1");
  auto w = number(image, "width"), h = number(image, "height");
  if (!x0 || !z0 || !x1 || !z1 || !w || !h || !(*w >= 1 && *w <= kTopDownMaxSide) || !(*h >= 1 && *h <= kTopDownMaxSide) ||
      !(*x1 > *x0) || !(*z1 > *z0)) {
    return makeError("the layout's image rectangle is missing or malformed");
  }
  TopDownImage out;
  out.width = uint32_t(*w);
  out.height = uint32_t(*h);
  out.rgba.assign(size_t(out.width) * out.height * 4, 0);
  const Bounds& b = scene.bounds;
  const float ground = number(&layout, "ground").value_or(b.empty() ? 0.0f : b.min.y);
  const float cut = number(&layout, "cut_height").value_or(b.empty() ? 1.0f : b.max.y + 1.0f);
  const float depthRange = std::max(cut - std::min(ground, b.empty() ? ground : b.min.y), 1e-3f) + 1.0f;
  const std::vector<glm::vec3> normals = faceNormals(scene);
  const float pixelX = (*x1 - *x0) / float(out.width), pixelZ = (*z1 - *z0) / float(out.height);
  for (uint32_t py = 0; py < out.height; ++py) {
    const float z = *z0 + (float(py) + 0.5f) / float(out.height) * (*z1 - *z0);
    for (uint32_t px = 0; px < out.width; ++px) {
      const float x = *x0 + (float(px) + 0.5f) / float(out.width) * (*x1 - *x0);
      uint8_t* p = &out.rgba[(size_t(py) * out.width + px) * 4];
      // A surface the cut crosses inside this pixel (a wall, even one of no
      // thickness): a section line, found by two rays along the pixel's
      // middle in x and in z.
      if (bvh.anyHit({{x - 0.5f * pixelX, cut, z}, {1.0f, 0.0f, 0.0f}, pixelX}) ||
          bvh.anyHit({{x, cut, z - 0.5f * pixelZ}, {0.0f, 0.0f, 1.0f}, pixelZ})) {
        p[0] = 24, p[1] = 26, p[2] = 32, p[3] = 255;
        continue;
      }
      std::optional<Hit> hit = bvh.closestHit({{x, cut, z}, {0.0f, -1.0f, 0.0f}});
      if (!hit) continue;  // transparent: nothing below
      if (hit->backFace) {
        // Cut through: the section's fill.
        p[0] = 52, p[1] = 54, p[2] = 62, p[3] = 255;
        continue;
      }
      // Light at the cut, darker with depth below it; slopes darker still.
      const float depth = std::clamp(hit->t / depthRange, 0.0f, 1.0f);
      const float up = hit->triangle < normals.size() ? std::abs(normals[hit->triangle].y) : 1.0f;
      const float shade = (0.95f - 0.55f * depth) * (0.6f + 0.4f * up);
      p[0] = uint8_t(std::clamp(shade * 236.0f, 0.0f, 255.0f));
      p[1] = uint8_t(std::clamp(shade * 228.0f, 0.0f, 255.0f));
      p[2] = uint8_t(std::clamp(shade * 212.0f, 0.0f, 255.0f));
      p[3] = 255;
    }
  }
  return out;
}

}  // namespace tally::scenes
