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

#include "analysis/image.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/visbuffer_base.hpp"
#include "scenes/mesh_builder.hpp"
#include "sweeps/fields.hpp"
#include "sweeps/skeleton.hpp"

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

// (i + k j) mod n for cell (i, j), cells of `cellSize` from the image's top-left corner.
uint32_t cellMaterial(int64_t i, int64_t j, uint32_t materials) {
  const int64_t k = materials == 2 ? 1 : 2;
  const int64_t n = materials;
  return uint32_t(((i + k * j) % n + n) % n);
}

int64_t floorDiv(int64_t a, int64_t b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

}  // namespace

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

// The selections to compare: those asked for (each must run here), or those
// the device can run, with why it runs none of the others.
struct Selections {
  std::vector<MaterialSelection> run;
  std::vector<std::string> skipped;
};

Result<Selections> selectionsToRun(gpu::Context& ctx, const EdgesSweepSpec& spec) {
  Selections out{spec.selections, {}};
  if (!out.run.empty()) {
    for (size_t i = 0; i < out.run.size(); ++i) {
      std::string why = renderers::materialSelectionUnsupported(ctx, out.run[i]);
      if (!why.empty()) return fieldError("selections[" + std::to_string(i) + "]", why);
    }
    return out;
  }
  for (auto s : {MaterialSelection::FirstLane, MaterialSelection::Uniform}) {
    std::string why = renderers::materialSelectionUnsupported(ctx, s);
    if (why.empty()) {
      out.run.push_back(s);
    } else {
      out.skipped.push_back(why);
    }
  }
  if (out.run.empty()) {
    std::string all;
    for (const auto& w : out.skipped) all += (all.empty() ? "" : "; ") + w;
    return makeError("selections: this device runs none of first-lane, uniform (" + all + ")");
  }
  return out;
}

// One cell size: the masks its layout gives on the CPU alone, and a second
// look at the layout in the reference image.
struct Layout {
  uint32_t cellSize = 0, width = 0, height = 0;
  size_t covered = 0;  // pixels the plane covers: all of them
  std::vector<uint8_t> quad, group, bins;
  size_t quadPixels = 0, groupPixels = 0;
  std::vector<size_t> pixelsByDistance;
  size_t mismatched = 0;     // reference pixels not of their material's colour
  size_t sharedColours = 0;  // materials in view whose colour another one in view has too
};

Layout layoutOf(const EdgesSweepSpec& spec, uint32_t cellSize, uint32_t subgroupSide,
                const std::vector<uint8_t>& reference) {
  const uint32_t width = spec.resolution.width, height = spec.resolution.height;
  const size_t pixelCount = size_t(width) * height;
  Layout out{cellSize, width, height, pixelCount};
  std::vector<uint32_t> labels(pixelCount);
  for (uint32_t y = 0; y < height; ++y) {
    for (uint32_t x = 0; x < width; ++x)
      labels[size_t(y) * width + x] = edgeMaterialAt(x, y, cellSize, spec.materials);
  }
  out.quad = blockMask(labels, width, height, 2);
  out.group = blockMask(labels, width, height, subgroupSide);
  out.bins = distanceBins(labels, width, height);
  out.quadPixels = size_t(std::count(out.quad.begin(), out.quad.end(), 1));
  out.groupPixels = size_t(std::count(out.group.begin(), out.group.end(), 1));
  out.pixelsByDistance.assign(kEdgeDistanceBins + 1, 0);
  for (uint8_t b : out.bins) ++out.pixelsByDistance[b];

  // In the reference every pixel of a material has that material's colour
  // (the most common one among its pixels).
  auto colourOf = [&](size_t i) {
    return uint32_t(reference[4 * i]) | uint32_t(reference[4 * i + 1]) << 8 |
           uint32_t(reference[4 * i + 2]) << 16;
  };
  std::vector<std::map<uint32_t, size_t>> histogram(spec.materials);
  for (size_t i = 0; i < pixelCount; ++i) ++histogram[labels[i]][colourOf(i)];
  std::vector<int64_t> colour(spec.materials, -1);
  for (uint32_t m = 0; m < spec.materials; ++m) {
    size_t best = 0;
    for (const auto& [c, n] : histogram[m]) {
      if (n > best) best = n, colour[m] = c;
    }
  }
  for (size_t i = 0; i < pixelCount; ++i) out.mismatched += colourOf(i) != colour[labels[i]];
  for (uint32_t m = 0; m < spec.materials; ++m) {
    for (uint32_t o = 0; o < spec.materials; ++o) {
      if (o != m && colour[m] >= 0 && colour[m] == colour[o]) {
        ++out.sharedColours;
        break;
      }
    }
  }
  return out;
}

// The point of one selection: its wrong pixels against the reference, by
// mask and by distance from the nearest boundary, and its image error.
Result<json> selectionPoint(const Layout& at, const std::string& name, const std::vector<uint8_t>& a,
                            const std::vector<uint8_t>& b, uint32_t subgroupSide) {
  const size_t pixelCount = size_t(at.width) * at.height;
  size_t wrong = 0, inQuad = 0, inGroup = 0;
  std::vector<size_t> wrongByDistance(kEdgeDistanceBins + 1, 0);
  json outsideAt = json::array();
  for (size_t i = 0; i < pixelCount; ++i) {
    int diff = 0;
    for (size_t c = 0; c < 3; ++c) diff = std::max(diff, std::abs(int(a[4 * i + c]) - int(b[4 * i + c])));
    if (diff <= kWrongTolerance) continue;
    ++wrong;
    inQuad += at.quad[i];
    inGroup += at.group[i];
    ++wrongByDistance[at.bins[i]];
    if (!at.group[i] && outsideAt.size() < kListedOutside) outsideAt.push_back({i % at.width, i / at.width});
  }
  auto whole = compareImages(a, b, at.width, at.height);
  if (!whole) return whole.failure();
  auto boundary = maskedError(a, b, at.group);
  if (!boundary) return boundary.failure();
  return json{
      {"selection", name},
      {"cell_size", at.cellSize},
      {"pixels", at.covered},
      {"wrong",
       {{"pixels", wrong},
        {"fraction", double(wrong) / double(at.covered)},
        {"in_quad_mask", inQuad},
        {"outside_quad_mask", wrong - inQuad},
        {"in_subgroup_mask", inGroup},
        {"outside_subgroup_mask", wrong - inGroup},
        {"outside_subgroup_mask_at", outsideAt},
        {"by_distance", wrongByDistance}}},
      {"error", errorJson(*whole, pixelCount)},
      {"boundary_error", *boundary},
      {"masks",
       {{"quad_pixels", at.quadPixels},
        {"quad_fraction", double(at.quadPixels) / double(pixelCount)},
        {"subgroup_pixels", at.groupPixels},
        {"subgroup_fraction", double(at.groupPixels) / double(pixelCount)},
        {"pixels_by_distance", at.pixelsByDistance}}},
      {"predicted",
       {{"quad_fraction", edgeBlockFraction(at.cellSize, 2)},
        {"subgroup_fraction", edgeBlockFraction(at.cellSize, subgroupSide)}}},
      {"layout_check",
       {{"mismatched_pixels", at.mismatched}, {"materials_sharing_a_colour", at.sharedColours}}},
  };
}

// The method: how the scene is laid out, what counts as wrong and what the masks assume.
json edgesMethod(const EdgesSweepSpec& spec, uint32_t subgroupSize, uint32_t subgroupSide,
                 const std::string& materialMaps) {
  const std::string distanceBinsNote =
      "index d - 1 counts pixels whose nearest pixel of another material is d "
      "pixels away (Chebyshev), d = 1.." +
      std::to_string(kEdgeDistanceBins) + "; the last index: farther, or none in view";
  return {
      {"scene",
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
       "(masks.*_fraction counts them on this image)"}};
}

}  // namespace

Result<json> runEdgesSweep(gpu::Context& ctx, const EdgesSweepSpec& spec, const SweepOptions& options) {
  const uint32_t width = spec.resolution.width, height = spec.resolution.height;
  const VkExtent2D extent = {width, height};
  const size_t pixelCount = size_t(width) * height;
  auto chosen = selectionsToRun(ctx, spec);
  if (!chosen) return chosen.failure();
  const std::vector<MaterialSelection>& selections = chosen->run;

  const uint32_t subgroupSize = ctx.subgroupSize;
  const uint32_t subgroupSide = subgroupBlockSide(subgroupSize);
  const scenes::Camera camera = edgeCamera();
  if (!options.screenshotDir.empty()) std::filesystem::create_directories(options.screenshotDir);
  auto screenshot = [&](const std::string& file, const std::vector<uint8_t>& rgba) {
    if (!options.screenshotDir.empty()) writePng(options.screenshotDir, file, rgba, width, height);
  };

  SweepRun run(ctx, options, spec.cellSizes.size() * (selections.size() + 1));
  std::string materialMaps;
  for (uint32_t cellSize : spec.cellSizes) {
    const std::string where = spec.renderer + " cell size " + std::to_string(cellSize);
    auto ran = run.withScene(
        edgeScene(spec, cellSize), where, [&](const renderers::GpuScene& gpuScene) -> Result<bool> {
          run.next(where + " nonuniform");
          auto reference =
              renderWith(ctx, gpuScene, spec.renderer, MaterialSelection::NonUniform, extent, camera);
          if (!reference) return makeError(where + " nonuniform: " + reference.error());
          materialMaps = reference->notes.value("material_maps", "");
          if (reference->image.size() != pixelCount * 4 || reference->depth.size() != pixelCount) {
            return makeError(where + ": the renderer returned no image or depth to read");
          }
          const size_t covered = size_t(std::count_if(reference->depth.begin(), reference->depth.end(),
                                                      [](float d) { return d < 1.0f; }));
          if (covered != pixelCount) {
            return makeError(where + ": " + std::to_string(pixelCount - covered) +
                             " pixels kept the cleared depth (the plane does not cover the view)");
          }
          const Layout layout = layoutOf(spec, cellSize, subgroupSide, reference->image);
          screenshot("edges_" + std::to_string(cellSize) + "_nonuniform.png", reference->image);

          for (auto selection : selections) {
            const std::string name(renderers::toString(selection));
            run.next(where + " " + name);
            auto frame = renderWith(ctx, gpuScene, spec.renderer, selection, extent, camera);
            if (!frame) return makeError(where + " " + name + ": " + frame.error());
            const auto& a = reference->image;
            const auto& b = frame->image;
            if (b.size() != a.size())
              return makeError(where + " " + name + ": the renderer returned no image");
            auto point = selectionPoint(layout, name, a, b, subgroupSide);
            if (!point) return makeError(where + " " + name + ": " + point.error());
            const std::string stem = "edges_" + std::to_string(cellSize) + "_" + name;
            screenshot(stem + ".png", b);
            screenshot(stem + "_difference.png", differenceImage(a, b));
            run.points.push_back(std::move(*point));
          }
          return true;
        });
    if (!ran) return ran.failure();
  }

  json report = {
      {"renderer", spec.renderer},
      {"parameters", {"selection", "cell_size"}},
      {"resolution", {width, height}},
      {"reference", "nonuniform"},
      {"selections", json::array()},
      {"method", edgesMethod(spec, subgroupSize, subgroupSide, materialMaps)},
      {"threshold", {{"boundary_error_fraction", spec.threshold}}},
      {"fails_at_rule",
       "per selection, the largest cell_size whose wrong.fraction reaches the threshold: cells "
       "shrink as cell_size falls, so it is where the selection first fails walking from large "
       "cells to small"},
      {"fails_at", failsAt(run.points, selections, spec.threshold)},
      {"plots", json::array({plot("Wrong pixels against material cell size", "cell_size", "wrong.fraction",
                                  false, "wrong pixels / covered pixels", {"selection"}, spec.threshold),
                             plot("Error on boundary pixels against material cell size", "cell_size",
                                  "boundary_error.mean_abs", false,
                                  "mean |difference| per channel over the subgroup mask (0..255)",
                                  {"selection"}, nullptr)})},
  };
  for (auto s : selections) report["selections"].push_back(renderers::toString(s));
  if (!chosen->skipped.empty()) report["selections_skipped"] = chosen->skipped;
  return run.finish(kEdgesSweepName, spec.source, std::move(report));
}

}  // namespace tally::sweeps
