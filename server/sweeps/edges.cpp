#include "sweeps/edges.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <numeric>

#include "sweeps/depth.hpp"  // kMaxSweepAxis
#include "analysis/image.hpp"
#include "sweeps/fields.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/visbuffer_base.hpp"
#include "scenes/mesh_builder.hpp"

namespace tally::sweeps {

using analysis::compareImages;
using analysis::differenceImage;
using analysis::encodePng;
using analysis::ImageError;
namespace {

using nlohmann::json;
using renderers::MaterialSelection;

// The camera sits at the origin looking down -Z (view = world) with a 60
// degree vertical field of view; the plane lies 2 m away, facing it, so its
// projection is affine and every cell spans the same number of pixels.
constexpr double kFovDeg = 60.0;
constexpr double kPlaneDistance = 2.0;  // metres
constexpr renderers::DepthRange kDepthRange = {0.5f, 8.0f};
// Diffuse maps: one flat colour each; with no mip or filter able to change a
// flat map, a wrong pixel can only come from a wrong map.
constexpr uint32_t kMapSize = 8;
// A pixel is wrong where any channel differs from the reference at all: the
// compared shaders differ only in the map index (the same_texture control
// shows the rest of the shading is bit-identical).
constexpr int kWrongTolerance = 0;
// Wrong pixels outside the subgroup mask listed by position, at most this many.
constexpr size_t kListedOutside = 16;

using fields::fieldError;
using fields::show;


// (i + k j) mod n for cell (i, j), cells of `cellSize` from the image's top-left corner.
uint32_t cellMaterial(int64_t i, int64_t j, uint32_t materials) {
  const int64_t k = materials == 2 ? 1 : 2;
  const int64_t n = materials;
  return uint32_t(((i + k * j) % n + n) % n);
}

int64_t floorDiv(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

}  // namespace

std::vector<std::string> edgeRenderers() { return {"visbuffer", "visbuffer-lean"}; }

uint32_t edgeMaterialAt(int64_t x, int64_t y, uint32_t cellSize, uint32_t materials) {
  return cellMaterial(floorDiv(x, cellSize), floorDiv(y, cellSize), materials);
}

double edgeBlockFraction(uint32_t cellSize, uint32_t block) {
  const uint64_t period = std::lcm(uint64_t{cellSize}, uint64_t{block});
  uint64_t crossed = 0;
  for (uint64_t start = 0; start < period; start += block) {
    // A cell edge at x = k s lies between pixels x - 1 and x; inside the block
    // when start < k s < start + block.
    uint64_t next = (start / cellSize + 1) * cellSize;
    if (next < start + block) ++crossed;
  }
  double f = double(crossed) / double(period / block);
  return 1.0 - (1.0 - f) * (1.0 - f);
}

uint32_t subgroupBlockSide(uint32_t subgroupSize) {
  uint32_t n = 2;
  while (uint64_t{n} * n < subgroupSize) n *= 2;
  return n;
}

Result<EdgesSweepSpec> parseEdgesSweepSpec(const json& j, const std::vector<std::string>& knownRenderers) {
  if (!j.is_object()) return fieldError("spec", "must be a JSON object, got " + show(j));
  if (auto e = json_fields::unknownKey(j, "",
                                       {"sweep", "renderer", "selections", "cell_sizes", "materials",
                                        "resolution", "same_texture", "threshold"}))
    return *e;
  EdgesSweepSpec spec;
  spec.source = j;

  if (j.contains("renderer")) {
    const auto& r = j["renderer"];
    std::string allowed;
    for (const auto& n : edgeRenderers()) allowed += (allowed.empty() ? "" : ", ") + n;
    if (!r.is_string()) return fieldError("renderer", "must be a renderer name (one of " + allowed + ")");
    std::string name = r.get<std::string>();
    if (std::find(knownRenderers.begin(), knownRenderers.end(), name) == knownRenderers.end()) {
      return fieldError("renderer", "unknown renderer '" + name + "' (expected one of " + allowed + ")");
    }
    auto ok = edgeRenderers();
    if (std::find(ok.begin(), ok.end(), name) == ok.end()) {
      return fieldError(
          "renderer",
          "'" + name + "' binds material maps per draw, not per pixel (expected one of " + allowed + ")");
    }
    spec.renderer = name;
  }

  if (j.contains("selections")) {
    const auto& s = j["selections"];
    const std::string expected =
        "\"first-lane\", \"uniform\" or \"nonuniform\" (the reference itself, a control)";
    if (!s.is_array() || s.empty() || s.size() > 3) {
      return fieldError("selections", "must be a non-empty array of " + expected + ", got " + show(s));
    }
    for (size_t i = 0; i < s.size(); ++i) {
      std::string f = "selections[" + std::to_string(i) + "]";
      auto parsed =
          s[i].is_string() ? renderers::parseMaterialSelection(s[i].get<std::string>()) : std::nullopt;
      if (!parsed) return fieldError(f, "must be " + expected + ", got " + show(s[i]));
      if (std::find(spec.selections.begin(), spec.selections.end(), *parsed) != spec.selections.end()) {
        return fieldError(f, show(s[i]) + " listed twice");
      }
      spec.selections.push_back(*parsed);
    }
  }

  if (j.contains("materials")) {
    const auto& m = j["materials"];
    if (!m.is_number_integer() || m.get<int64_t>() < 2 || m.get<int64_t>() > kMaxEdgeMaterials) {
      return fieldError("materials", "must be an integer from 2 to " + std::to_string(kMaxEdgeMaterials) +
                                         ", got " + show(m));
    }
    spec.materials = uint32_t(m.get<int64_t>());
  }

  if (j.contains("same_texture")) {
    if (!j["same_texture"].is_boolean()) {
      return fieldError("same_texture", "must be true or false, got " + show(j["same_texture"]));
    }
    spec.sameTexture = j["same_texture"].get<bool>();
  }

  if (j.contains("resolution")) {
    auto r = fields::resolution(j["resolution"]);
    if (!r) return r.failure();
    spec.resolution = *r;
  }

  // Whole pixels: cell edges then fall on pixel edges, half a pixel from every
  // sample point, so the CPU layout and the rasteriser cannot disagree.
  if (!j.contains("cell_sizes")) return fieldError("cell_sizes", "required, e.g. [64, 16, 4, 2, 1]");
  const auto& c = j["cell_sizes"];
  if (!c.is_array() || c.empty() || c.size() > kMaxSweepAxis) {
    return fieldError("cell_sizes", "must be an array of 1 to " + std::to_string(kMaxSweepAxis) +
                                        " whole pixel counts, got " + show(c));
  }
  for (size_t i = 0; i < c.size(); ++i) {
    std::string f = "cell_sizes[" + std::to_string(i) + "]";
    if (!c[i].is_number_integer() || c[i].get<int64_t>() < 1 || c[i].get<int64_t>() > kMaxEdgeCellSize) {
      return fieldError(f, "must be a whole number of pixels from 1 to " + std::to_string(kMaxEdgeCellSize) +
                               ", got " + show(c[i]));
    }
    uint32_t s = uint32_t(c[i].get<int64_t>());
    if (std::find(spec.cellSizes.begin(), spec.cellSizes.end(), s) != spec.cellSizes.end()) {
      return fieldError(f, std::to_string(s) + " listed twice");
    }
    const uint64_t cells = (uint64_t{spec.resolution.width + s - 1} / s + 2) *
                           (uint64_t{spec.resolution.height + s - 1} / s + 2);
    if (cells > kMaxEdgeCells) {
      return fieldError(f, "cells of " + std::to_string(s) + " pixels at " +
                               std::to_string(spec.resolution.width) + "x" +
                               std::to_string(spec.resolution.height) + " are " + std::to_string(cells) +
                               " cells, more than the limit of " + std::to_string(kMaxEdgeCells));
    }
    spec.cellSizes.push_back(s);
  }

  if (!j.contains("threshold"))
    return fieldError("threshold", "required, e.g. {\"boundary_error_fraction\": 0.01}");
  const auto& t = j["threshold"];
  if (!t.is_object() || t.size() != 1 || !t.contains("boundary_error_fraction")) {
    return fieldError(
        "threshold",
        "must be {\"boundary_error_fraction\": x} (wrong pixels / covered pixels), got " + show(t));
  }
  const auto& tv = t["boundary_error_fraction"];
  if (!tv.is_number() || !std::isfinite(tv.get<double>()) || tv.get<double>() <= 0 || tv.get<double>() > 1) {
    return fieldError("threshold.boundary_error_fraction", "must be a number in (0, 1], got " + show(tv));
  }
  spec.threshold = tv.get<double>();
  return spec;
}

namespace {

// A fully saturated hue per material, spread around the colour wheel.
std::array<uint8_t, 4> materialColour(uint32_t material, uint32_t materials) {
  double h = 6.0 * double(material) / double(materials);
  int sector = int(h) % 6;
  double f = h - std::floor(h);
  double r = 0, g = 0, b = 0;
  switch (sector) {
    case 0: r = 1, g = f; break;
    case 1: r = 1 - f, g = 1; break;
    case 2: g = 1, b = f; break;
    case 3: g = 1 - f, b = 1; break;
    case 4: r = f, b = 1; break;
    default: r = 1, b = 1 - f; break;
  }
  auto byte = [](double v) { return uint8_t(std::lround(v * 255.0)); };
  return {byte(r), byte(g), byte(b), 255};
}

}  // namespace

// One mesh (draw) per material holding all its cells, so draws = materials,
// far inside the visibility id's 512.
scenes::Scene edgeScene(const EdgesSweepSpec& spec, uint32_t cellSize) {
  const uint32_t width = spec.resolution.width, height = spec.resolution.height;
  scenes::Scene scene;
  scene.name = "material-edges";
  for (uint32_t m = 0; m < spec.materials; ++m) {
    scenes::Texture t;
    t.name = "edge-" + std::to_string(m) + ".diffuse";
    t.width = t.height = kMapSize;
    t.srgb = true;
    auto colour = materialColour(spec.sameTexture ? 0 : m, spec.materials);
    for (uint32_t i = 0; i < kMapSize * kMapSize; ++i)
      t.rgba8.insert(t.rgba8.end(), colour.begin(), colour.end());
    scenes::Material material;
    material.name = "edge-" + std::to_string(m);
    material.maps[size_t(scenes::MapSlot::Diffuse)] = int32_t(scene.textures.size());
    scene.textures.push_back(std::move(t));
    scene.materials.push_back(material);
  }
  // Pixel edge (X, Y) on the plane z = -d: one pixel is 2 d tan(fov / 2) / height metres.
  const double pixel = 2.0 * kPlaneDistance * std::tan(kFovDeg * std::numbers::pi / 360.0) / height;
  auto at = [&](int64_t x, int64_t y) {
    return glm::vec3(float((double(x) - width / 2.0) * pixel), float((height / 2.0 - double(y)) * pixel),
                     float(-kPlaneDistance));
  };
  const glm::vec3 X(1, 0, 0), Y(0, 1, 0), Z(0, 0, 1);
  std::vector<scenes::MeshBuilder> builders(spec.materials);
  const int64_t s = cellSize, columns = (width + s - 1) / s, rows = (height + s - 1) / s;
  for (int64_t j = -1; j <= rows; ++j) {
    for (int64_t i = -1; i <= columns; ++i) {
      builders[cellMaterial(i, j, spec.materials)].quad(at(i * s, (j + 1) * s), at((i + 1) * s, (j + 1) * s),
                                                        at((i + 1) * s, j * s), at(i * s, j * s), Z, X, Y,
                                                        float(pixel * s));
    }
  }
  for (uint32_t m = 0; m < spec.materials; ++m) {
    scenes::Mesh mesh = builders[m].finish("cells-" + std::to_string(m), m);
    if (!mesh.indices.empty()) scene.meshes.push_back(std::move(mesh));
  }
  scenes::updateBounds(scene);
  return scene;
}

scenes::Camera edgeCamera() {
  scenes::Camera camera;
  camera.eye = glm::vec3(0.0f);
  camera.target = glm::vec3(0.0f, 0.0f, -1.0f);
  camera.fovDeg = float(kFovDeg);
  camera.label = "head-on";
  return camera;
}

namespace {

struct Frame {
  std::vector<uint8_t> image;
  std::vector<float> depth;
  json notes;
};

Result<Frame> renderWith(gpu::Context& ctx, const renderers::GpuScene& scene, const std::string& rendererName,
                         MaterialSelection selection, VkExtent2D extent, const scenes::Camera& camera) {
  auto made = renderers::makeRenderer(rendererName);
  if (!made) return made.failure();
  // Uninstrumented, no point lights: the colour is ambient x diffuse map, so
  // a wrong map is a wrong colour and nothing else differs.
  renderers::RendererOptions ro{extent, false, spirv::Mode{}, 0, kDepthRange};
  ro.materialSelection = selection;
  auto ok = (*made)->setup(ctx, scene, ro);
  if (!ok) return ok.failure();
  (*made)->renderFrame(camera);
  Frame f{(*made)->finalImage(), (*made)->depthImage(), (*made)->notes()};
  (*made)->destroy();
  return f;
}

// Pixels whose aligned `block` x `block` square (clipped to the image) holds
// more than one material.
std::vector<uint8_t> blockMask(const std::vector<uint32_t>& labels, uint32_t width, uint32_t height,
                               uint32_t block) {
  std::vector<uint8_t> mask(labels.size(), 0);
  for (uint32_t by = 0; by < height; by += block) {
    for (uint32_t bx = 0; bx < width; bx += block) {
      const uint32_t x1 = std::min(width, bx + block), y1 = std::min(height, by + block);
      bool mixed = false;
      for (uint32_t y = by; y < y1 && !mixed; ++y) {
        for (uint32_t x = bx; x < x1 && !mixed; ++x)
          mixed = labels[size_t(y) * width + x] != labels[size_t(by) * width + bx];
      }
      if (!mixed) continue;
      for (uint32_t y = by; y < y1; ++y) {
        for (uint32_t x = bx; x < x1; ++x) mask[size_t(y) * width + x] = 1;
      }
    }
  }
  return mask;
}

// Chebyshev distance to the nearest pixel (in the image) of another
// material, as a bin: d - 1 for d <= kEdgeDistanceBins, else the last bin.
std::vector<uint8_t> distanceBins(const std::vector<uint32_t>& labels, uint32_t width, uint32_t height) {
  std::vector<uint8_t> bins(labels.size(), uint8_t(kEdgeDistanceBins));
  for (int64_t y = 0; y < int64_t(height); ++y) {
    for (int64_t x = 0; x < int64_t(width); ++x) {
      const uint32_t own = labels[size_t(y) * width + size_t(x)];
      auto differs = [&](int64_t px, int64_t py) {
        return px >= 0 && py >= 0 && px < int64_t(width) && py < int64_t(height) &&
               labels[size_t(py) * width + size_t(px)] != own;
      };
      for (int64_t r = 1; r <= kEdgeDistanceBins; ++r) {
        bool found = false;
        for (int64_t t = -r; t <= r && !found; ++t) {
          found = differs(x + t, y - r) || differs(x + t, y + r) || differs(x - r, y + t) ||
                  differs(x + r, y + t);
        }
        if (found) {
          bins[size_t(y) * width + size_t(x)] = uint8_t(r - 1);
          break;
        }
      }
    }
  }
  return bins;
}

json errorJson(const ImageError& e, size_t pixels) {
  return {{"max_abs", e.maxAbs},
          {"mean_abs", e.meanAbs},
          {"psnr", std::isinf(e.psnr) ? json(nullptr) : json(e.psnr)},
          {"identical", std::isinf(e.psnr)},
          {"pixels", pixels}};
}

// compareImages over the pixels of `mask` only (gathered into one row).
Result<json> maskedError(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b,
                         const std::vector<uint8_t>& mask) {
  std::vector<uint8_t> ga, gb;
  for (size_t i = 0; i < mask.size(); ++i) {
    if (!mask[i]) continue;
    ga.insert(ga.end(), a.begin() + ptrdiff_t(4 * i), a.begin() + ptrdiff_t(4 * i + 4));
    gb.insert(gb.end(), b.begin() + ptrdiff_t(4 * i), b.begin() + ptrdiff_t(4 * i + 4));
  }
  const size_t pixels = ga.size() / 4;
  if (pixels == 0) {
    return json{{"max_abs", 0}, {"mean_abs", 0.0}, {"psnr", nullptr}, {"identical", true}, {"pixels", 0}};
  }
  auto e = compareImages(ga, gb, uint32_t(pixels), 1);
  if (!e) return e.failure();
  return errorJson(*e, pixels);
}

void writePng(const std::string& dir, const std::string& file, const std::vector<uint8_t>& rgba,
              uint32_t width, uint32_t height) {
  auto png = encodePng(rgba, width, height);
  std::ofstream out(std::filesystem::path(dir) / file, std::ios::binary);
  out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
}

// Per selection, the largest cell size whose wrong fraction reaches the
// threshold: cells shrink as the parameter falls, so this is where the method
// first fails walking from big cells to small. Null where none does; null
// overall when no point fails.
json failsAt(const json& points, const std::vector<MaterialSelection>& selections, double threshold) {
  json out = json::array();
  bool any = false;
  for (auto s : selections) {
    json entry = {{"selection", renderers::toString(s)}, {"cell_size", nullptr}};
    for (const auto& p : points) {
      if (p["selection"] != renderers::toString(s) || p["wrong"]["fraction"].get<double>() < threshold)
        continue;
      any = true;
      if (entry["cell_size"].is_null() ||
          p["cell_size"].get<uint32_t>() > entry["cell_size"].get<uint32_t>()) {
        entry["cell_size"] = p["cell_size"];
      }
    }
    out.push_back(entry);
  }
  return any ? out : json(nullptr);
}

}  // namespace

Result<json> runEdgesSweep(gpu::Context& ctx, const EdgesSweepSpec& spec, const SweepOptions& options) {
  const uint32_t width = spec.resolution.width, height = spec.resolution.height;
  const VkExtent2D extent = {width, height};
  const size_t pixelCount = size_t(width) * height;

  // Which selections: those asked for (each must run here), or those the device can run.
  std::vector<MaterialSelection> selections = spec.selections;
  std::vector<std::string> skipped;
  if (selections.empty()) {
    for (auto s : {MaterialSelection::FirstLane, MaterialSelection::Uniform}) {
      std::string why = renderers::materialSelectionUnsupported(ctx, s);
      if (why.empty()) {
        selections.push_back(s);
      } else {
        skipped.push_back(why);
      }
    }
    if (selections.empty()) {
      std::string all;
      for (const auto& w : skipped) all += (all.empty() ? "" : "; ") + w;
      return makeError("selections: this device runs none of first-lane, uniform (" + all + ")");
    }
  } else {
    for (size_t i = 0; i < selections.size(); ++i) {
      std::string why = renderers::materialSelectionUnsupported(ctx, selections[i]);
      if (!why.empty()) return fieldError("selections[" + std::to_string(i) + "]", why);
    }
  }

  const uint32_t subgroupSize = ctx.subgroupSize;
  const uint32_t subgroupSide = subgroupBlockSide(subgroupSize);
  const scenes::Camera camera = edgeCamera();
  if (!options.screenshotDir.empty()) std::filesystem::create_directories(options.screenshotDir);

  Progress progress{0, spec.cellSizes.size() * (selections.size() + 1), ""};
  json points = json::array();
  std::string materialMaps;
  for (uint32_t cellSize : spec.cellSizes) {
    const std::string where = spec.renderer + " cell size " + std::to_string(cellSize);
    scenes::Scene scene = edgeScene(spec, cellSize);
    renderers::GpuScene gpuScene;
    auto uploaded = gpuScene.upload(ctx, scene);
    if (!uploaded) return makeError(where + ": " + uploaded.error());

    progress.current = where + " nonuniform";
    if (options.progress) options.progress(progress);
    auto reference = renderWith(ctx, gpuScene, spec.renderer, MaterialSelection::NonUniform, extent, camera);
    if (!reference) return makeError(where + " nonuniform: " + reference.error());
    ++progress.done;
    materialMaps = reference->notes.value("material_maps", "");
    if (reference->image.size() != pixelCount * 4 || reference->depth.size() != pixelCount) {
      return makeError(where + ": the renderer returned no image or depth to read");
    }
    const size_t covered = size_t(
        std::count_if(reference->depth.begin(), reference->depth.end(), [](float d) { return d < 1.0f; }));
    if (covered != pixelCount) {
      return makeError(where + ": " + std::to_string(pixelCount - covered) +
                       " pixels kept the cleared depth (the plane does not cover the view)");
    }

    // The layout on the CPU, and the masks from it alone.
    std::vector<uint32_t> labels(pixelCount);
    for (uint32_t y = 0; y < height; ++y) {
      for (uint32_t x = 0; x < width; ++x)
        labels[size_t(y) * width + x] = edgeMaterialAt(x, y, cellSize, spec.materials);
    }
    const std::vector<uint8_t> quad = blockMask(labels, width, height, 2);
    const std::vector<uint8_t> group = blockMask(labels, width, height, subgroupSide);
    const std::vector<uint8_t> bins = distanceBins(labels, width, height);
    const size_t quadPixels = size_t(std::count(quad.begin(), quad.end(), 1));
    const size_t groupPixels = size_t(std::count(group.begin(), group.end(), 1));
    std::vector<size_t> pixelsByDistance(kEdgeDistanceBins + 1, 0);
    for (uint8_t b : bins) ++pixelsByDistance[b];

    // A second look at the layout: in the reference every pixel of a material
    // has that material's colour (the most common one among its pixels).
    auto colourOf = [&](const std::vector<uint8_t>& image, size_t i) {
      return uint32_t(image[4 * i]) | uint32_t(image[4 * i + 1]) << 8 | uint32_t(image[4 * i + 2]) << 16;
    };
    std::vector<std::map<uint32_t, size_t>> histogram(spec.materials);
    for (size_t i = 0; i < pixelCount; ++i) ++histogram[labels[i]][colourOf(reference->image, i)];
    std::vector<int64_t> colour(spec.materials, -1);
    for (uint32_t m = 0; m < spec.materials; ++m) {
      size_t best = 0;
      for (const auto& [c, n] : histogram[m]) {
        if (n > best) best = n, colour[m] = c;
      }
    }
    size_t mismatched = 0;
    for (size_t i = 0; i < pixelCount; ++i) mismatched += colourOf(reference->image, i) != colour[labels[i]];
    size_t sharedColours = 0;  // materials in view whose colour another one in view has too
    for (uint32_t m = 0; m < spec.materials; ++m) {
      for (uint32_t o = 0; o < spec.materials; ++o) {
        if (o != m && colour[m] >= 0 && colour[m] == colour[o]) {
          ++sharedColours;
          break;
        }
      }
    }
    if (!options.screenshotDir.empty()) {
      writePng(options.screenshotDir, "edges_" + std::to_string(cellSize) + "_nonuniform.png",
               reference->image, width, height);
    }

    for (auto selection : selections) {
      const std::string name(renderers::toString(selection));
      progress.current = where + " " + name;
      if (options.progress) options.progress(progress);
      auto frame = renderWith(ctx, gpuScene, spec.renderer, selection, extent, camera);
      if (!frame) return makeError(where + " " + name + ": " + frame.error());
      ++progress.done;
      const auto& a = reference->image;
      const auto& b = frame->image;
      if (b.size() != a.size()) return makeError(where + " " + name + ": the renderer returned no image");

      size_t wrong = 0, inQuad = 0, inGroup = 0;
      std::vector<size_t> wrongByDistance(kEdgeDistanceBins + 1, 0);
      json outsideAt = json::array();
      for (size_t i = 0; i < pixelCount; ++i) {
        int diff = 0;
        for (size_t c = 0; c < 3; ++c) diff = std::max(diff, std::abs(int(a[4 * i + c]) - int(b[4 * i + c])));
        if (diff <= kWrongTolerance) continue;
        ++wrong;
        inQuad += quad[i];
        inGroup += group[i];
        ++wrongByDistance[bins[i]];
        if (!group[i] && outsideAt.size() < kListedOutside) outsideAt.push_back({i % width, i / width});
      }
      auto whole = compareImages(a, b, width, height);
      if (!whole) return makeError(where + " " + name + ": " + whole.error());
      auto boundary = maskedError(a, b, group);
      if (!boundary) return makeError(where + " " + name + ": " + boundary.error());
      if (!options.screenshotDir.empty()) {
        std::string stem = "edges_" + std::to_string(cellSize) + "_" + name;
        writePng(options.screenshotDir, stem + ".png", b, width, height);
        writePng(options.screenshotDir, stem + "_difference.png", differenceImage(a, b), width, height);
      }

      points.push_back({
          {"selection", name},
          {"cell_size", cellSize},
          {"pixels", covered},
          {"wrong",
           {{"pixels", wrong},
            {"fraction", double(wrong) / double(covered)},
            {"in_quad_mask", inQuad},
            {"outside_quad_mask", wrong - inQuad},
            {"in_subgroup_mask", inGroup},
            {"outside_subgroup_mask", wrong - inGroup},
            {"outside_subgroup_mask_at", outsideAt},
            {"by_distance", wrongByDistance}}},
          {"error", errorJson(*whole, pixelCount)},
          {"boundary_error", *boundary},
          {"masks",
           {{"quad_pixels", quadPixels},
            {"quad_fraction", double(quadPixels) / double(pixelCount)},
            {"subgroup_pixels", groupPixels},
            {"subgroup_fraction", double(groupPixels) / double(pixelCount)},
            {"pixels_by_distance", pixelsByDistance}}},
          {"predicted",
           {{"quad_fraction", edgeBlockFraction(cellSize, 2)},
            {"subgroup_fraction", edgeBlockFraction(cellSize, subgroupSide)}}},
          {"layout_check",
           {{"mismatched_pixels", mismatched}, {"materials_sharing_a_colour", sharedColours}}},
      });
    }
    gpuScene.destroy();
  }
  progress.current = "done";
  if (options.progress) options.progress(progress);

  const std::string distanceBinsNote =
      "index d - 1 counts pixels whose nearest pixel of another material is d "
      "pixels away (Chebyshev), d = 1.." +
      std::to_string(kEdgeDistanceBins) + "; the last index: farther, or none in view";
  json result = {
      {"sweep", std::string(kEdgesSweepName)},
      {"device", gpu::describe(ctx)},
      {"spec", spec.source},
      {"renderer", spec.renderer},
      {"parameters", {"selection", "cell_size"}},
      {"resolution", {width, height}},
      {"reference", "nonuniform"},
      {"selections", json::array()},
      {"method",
       {{"scene",
         "a plane facing the camera, covering the view, split into square cells of cell_size pixels "
         "from the image's top-left corner; cell (i, j) has material (i + k j) mod materials, k = 1 for "
         "2 materials, else 2; one draw per material"},
        {"materials", spec.materials},
        {"same_texture", spec.sameTexture},
        {"diffuse_maps", std::to_string(kMapSize) + "x" + std::to_string(kMapSize) +
                             " flat sRGB, one hue per material; other maps the renderer's 1x1 defaults"},
        {"lighting", "ambient only (no point lights): colour = ambient x diffuse map"},
        {"fov_deg", kFovDeg},
        {"plane_distance", kPlaneDistance},
        {"material_maps", materialMaps},
        {"wrong_pixel", "any RGB channel of the final RGBA8 image differs from the reference by more than " +
                            std::to_string(kWrongTolerance)},
        {"quad_mask",
         "pixels whose 2x2 quad (aligned to even pixels) holds more than one material, from the layout"},
        {"subgroup_size", subgroupSize},
        {"subgroup_mask",
         "pixels whose aligned " + std::to_string(subgroupSide) + "x" + std::to_string(subgroupSide) +
             " block holds more than one material, from the layout; assumes a subgroup's fragments lie in "
             "one "
             "aligned power-of-two rectangle of quads no wider or taller than that (the smallest such square "
             "with room for subgroup_size lanes)"},
        {"boundary_error", "compareImages over the subgroup mask's pixels"},
        {"distance_bins", distanceBinsNote},
        {"predicted",
         "the mask fractions of an infinite plane of these cells, derived per axis over one period "
         "(masks.*_fraction counts them on this image)"}}},
      {"threshold", {{"boundary_error_fraction", spec.threshold}}},
      {"fails_at_rule",
       "per selection, the largest cell_size whose wrong.fraction reaches the threshold: cells "
       "shrink as cell_size falls, so it is where the selection first fails walking from large "
       "cells to small"},
      {"points", points},
  };
  for (auto s : selections) result["selections"].push_back(renderers::toString(s));
  if (!skipped.empty()) result["selections_skipped"] = skipped;
  result["fails_at"] = failsAt(points, selections, spec.threshold);
  result["plots"] =
      json::array({{{"title", "Wrong pixels against material cell size"},
                    {"x", "cell_size"},
                    {"x_log", true},
                    {"y", "wrong.fraction"},
                    {"y_log", false},
                    {"y_label", "wrong pixels / covered pixels"},
                    {"series", {"selection"}},
                    {"threshold", spec.threshold}},
                   {{"title", "Error on boundary pixels against material cell size"},
                    {"x", "cell_size"},
                    {"x_log", true},
                    {"y", "boundary_error.mean_abs"},
                    {"y_log", false},
                    {"y_label", "mean |difference| per channel over the subgroup mask (0..255)"},
                    {"series", {"selection"}},
                    {"threshold", nullptr}}});
  return result;
}

}  // namespace tally::sweeps
