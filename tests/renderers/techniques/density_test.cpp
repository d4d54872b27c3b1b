// Forward output=density (docs/techniques.md, "Mesh density"), on scenes
// built here from pixel-exact grids seen head-on (a plane at a known
// distance, vertices placed in pixel units), so that every figure follows
// from the grid parameters:
// - the census classifies exactly the triangles the construction makes
//   sub-pixel, long-thin and normal, with their log2 area buckets;
// - the view colours exactly the pixel centres each grid covers (no centre
//   lies within 0.1 px of any edge, so the counts are exact, not approximate);
// - quad lanes: a full-screen rectangle of two triangles launches one quad
//   per 2x2 block plus one more per block its diagonal splits; a grid of
//   triangles that each cover at most one pixel centre launches a whole quad
//   (4 lanes) per covered pixel;
// - the option table takes output=density for forward and forward-zprepass only.
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "render_fixture.hpp"
#include "renderers/options.hpp"
#include "scenes/mesh_builder.hpp"
#include "scenes/textures.hpp"

namespace tally::renderers {
namespace {

constexpr VkExtent2D kExtent = {128, 72};  // even: whole 2x2 quads
constexpr float kDistance = 2.0f;          // metres from the eye to the grids
constexpr float kFovDeg = 60.0f;

// World position of framebuffer pixel coordinates (px, py) on the plane at
// kDistance, for the head-on camera: one pixel is 2 d tan(fov / 2) / H metres.
glm::vec3 atPixel(double px, double py) {
  const double s = 2.0 * kDistance * std::tan(glm::radians(double(kFovDeg)) * 0.5) / kExtent.height;
  return glm::vec3(float((px - kExtent.width * 0.5) * s), float((kExtent.height * 0.5 - py) * s), -kDistance);
}

// A grid of nx x ny cells of cw x ch pixels from pixel (x0, y0), each cell
// split along its (x0, y0)-(x0 + cw, y0 + ch) diagonal: 2 nx ny triangles
// facing the camera, shared vertices.
scenes::Mesh grid(double x0, double y0, int nx, int ny, double cw, double ch, uint32_t material) {
  scenes::MeshBuilder b;
  const glm::vec3 n(0.0f, 0.0f, 1.0f);
  std::vector<uint32_t> ids;
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) ids.push_back(b.vertex(atPixel(x0 + i * cw, y0 + j * ch), n, glm::vec2(i, j) * 0.1f));
  }
  auto id = [&](int i, int j) { return ids[size_t(j) * size_t(nx + 1) + size_t(i)]; };
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      b.triangle(id(i, j), id(i + 1, j), id(i + 1, j + 1), n);
      b.triangle(id(i, j), id(i + 1, j + 1), id(i, j + 1), n);
    }
  }
  return b.finish("grid", material);
}

struct Grid {
  double x0, y0;
  int nx, ny;
  double cw, ch;
};

struct DensityRun {
  bool ok = false;
  nlohmann::json density;
  std::vector<std::string> passes;
  std::vector<ResourceInfo> resources;
  uint64_t forwardFragments = 0;
};

DensityRun renderGrids(const std::vector<Grid>& grids, const std::string& renderer = "forward") {
  DensityRun out;
  gpu::Context* ctx = fixture::context();
  if (ctx == nullptr) return out;
  scenes::Scene scene;
  scene.name = "density grids";
  const uint32_t material = scenes::addProceduralMaterial(scene, scenes::ProceduralMaterial::Tiles, 64);
  for (const auto& g : grids) scene.meshes.push_back(grid(g.x0, g.y0, g.nx, g.ny, g.cw, g.ch, material));
  scenes::updateBounds(scene);
  GpuScene gpuScene;
  auto uploaded = gpuScene.upload(*ctx, scene);
  EXPECT_TRUE(uploaded.ok()) << (uploaded ? "" : uploaded.error());
  if (!uploaded) return out;
  auto r = makeRenderer(renderer);
  EXPECT_TRUE(r.ok());
  if (!r) return out;
  RendererOptions options;
  options.extent = kExtent;
  options.lights = fixture::kTestLights;
  options.forwardOutput = ForwardOutput::Density;
  auto ok = (*r)->setup(*ctx, gpuScene, options);
  EXPECT_TRUE(ok.ok()) << (ok ? "" : ok.error());
  if (!ok) return out;
  scenes::Camera camera;
  camera.fovDeg = kFovDeg;
  FrameResult frame = (*r)->renderFrame(camera);
  out.density = (*r)->frameExtras().value("density", nlohmann::json());
  out.passes = (*r)->passNames();
  out.resources = (*r)->resources();
  for (const auto& p : frame.passes) {
    if (p.name == "forward") out.forwardFragments = p.fragmentInvocations;
  }
  std::printf("  density: %s\n  notes: %s\n", out.density.dump().c_str(), (*r)->notes().dump().c_str());
  (*r)->destroy();
  gpuScene.destroy();
  out.ok = !out.density.is_null();
  return out;
}

// The three classes side by side, rows 12.35..60.35 (pixel centres 12.5 ..
// 59.5: 48 rows; mirrored, 11.65..59.65, the same rows). Cell origins at
// x = k + 0.1, so a centre sits 0.4 px right of a cell's left edge, and
// 0.15 px (0.35 mirrored) below its top: never within 0.1 px of an edge or
// either diagonal.
// - sub-pixel: 0.5 x 0.5 px cells over 32 x 48 px: 64 x 96 cells, triangles of 0.125 px^2;
// - long-thin: 0.5 x 48 px strips over 32 px: 64 strips, triangles of 12 px^2 whose smallest
//   altitude is 2 x 12 / sqrt(0.5^2 + 48^2) = 0.49997 px;
// - normal: 8 x 8 px cells over 40 x 48 px: 5 x 6 cells, 32 px^2, altitude 8 / sqrt(2) = 5.66 px.
const std::vector<Grid> kClassGrids = {{4.1, 12.35, 64, 96, 0.5, 0.5},
                                       {44.1, 12.35, 64, 1, 0.5, 48.0},
                                       {84.1, 12.35, 5, 6, 8.0, 8.0}};

TEST(Density, CensusClassifiesTheGridsTriangles) {
  DensityRun r = renderGrids(kClassGrids);
  ASSERT_TRUE(r.ok);
  const nlohmann::json& d = r.density;
  const uint64_t sub = 2 * 64 * 96, thin = 2 * 64, normal = 2 * 5 * 6;
  EXPECT_EQ(d.at("triangles_submitted").get<uint64_t>(), sub + thin + normal);
  EXPECT_EQ(d.at("triangles_in_view").get<uint64_t>(), sub + thin + normal);
  EXPECT_EQ(d.at("triangles_front_facing").get<uint64_t>(), sub + thin + normal);  // built facing the camera
  EXPECT_EQ(d.at("triangles_clipped_near").get<uint64_t>(), 0u);
  EXPECT_EQ(d.at("sub_pixel").get<uint64_t>(), sub);
  EXPECT_EQ(d.at("long_thin").get<uint64_t>(), thin);
  EXPECT_EQ(d.at("normal").get<uint64_t>(), normal);
  EXPECT_EQ(d.at("problematic").get<uint64_t>(), sub + thin);
  // log2 buckets: 0.125 = 2^-3 and 32 = 2^5 px^2 lie on bucket edges, so
  // float vertex rounding puts them in bucket -4 or -3, 4 or 5; 12 px^2 is
  // inside [2^3, 2^4).
  std::map<int, uint64_t> buckets;
  for (const auto& b : d.at("area_histogram")) buckets[b.at("log2_area").get<int>()] = b.at("triangles").get<uint64_t>();
  EXPECT_EQ(buckets[-4] + buckets[-3], sub);
  EXPECT_EQ(buckets[3], thin);
  EXPECT_EQ(buckets[4] + buckets[5], normal);
  // Passes and targets: no heat view, the lane target beside the count target.
  EXPECT_EQ(r.passes, (std::vector<std::string>{"forward", "tonemap", "skybox"}));
  bool lanes = false;
  for (const auto& res : r.resources) lanes = lanes || (res.name == "density.lanes" && res.formatName == "R32_SFLOAT");
  EXPECT_TRUE(lanes);
}

TEST(Density, ViewColoursEachGridsPixelsByItsClass) {
  DensityRun r = renderGrids(kClassGrids);
  ASSERT_TRUE(r.ok);
  const nlohmann::json& px = r.density.at("pixels");
  // Pixel centres inside each grid's rectangle (no centre near an edge: exact).
  const uint64_t rows = 48, sub = 32 * rows, thin = 32 * rows, normal = 40 * rows;
  EXPECT_EQ(px.at("sub_pixel").get<uint64_t>(), sub);
  EXPECT_EQ(px.at("long_thin").get<uint64_t>(), thin);
  EXPECT_EQ(px.at("normal").get<uint64_t>(), normal);
  EXPECT_EQ(px.at("other").get<uint64_t>(), uint64_t(kExtent.width) * kExtent.height - sub - thin - normal);
  // One visible layer: fragments = covered pixels, as the counters counted.
  EXPECT_EQ(r.density.at("covered_pixels").get<uint64_t>(), sub + thin + normal);
  EXPECT_EQ(r.density.at("fragments").get<uint64_t>(), sub + thin + normal);
  EXPECT_EQ(r.density.at("counted_fragments").get<uint64_t>(), r.forwardFragments);
  EXPECT_TRUE(r.density.at("agrees").get<bool>());
  EXPECT_DOUBLE_EQ(r.density.at("overshading").get<double>(), 1.0);
}

// The lanes of the source the device has; the CPU estimate is there either way.
double quadOvershading(const nlohmann::json& d) { return d.at("quad").at("quad_overshading").get<double>(); }

TEST(Density, QuadOvershadingOfAFullScreenRectangleIsItsDiagonalsQuads) {
  // Corners 0.37 px (x) and 0.21 px (y) outside the screen: every pixel
  // covered once; symmetric, so a vertical flip gives the same counts.
  const double x0 = -0.37, y0 = -0.21, x1 = kExtent.width + 0.37, y1 = kExtent.height + 0.21;
  DensityRun r = renderGrids({{x0, y0, 1, 1, x1 - x0, y1 - y0}});
  ASSERT_TRUE(r.ok);
  // Derivation: the 2x2 blocks whose centres lie on both sides of the
  // diagonal are launched by both triangles; every other block by one.
  uint64_t split = 0;
  double nearest = 1e9;
  for (uint32_t qy = 0; qy < kExtent.height; qy += 2) {
    for (uint32_t qx = 0; qx < kExtent.width; qx += 2) {
      bool above = false, below = false;
      for (int k = 0; k < 4; ++k) {
        const double x = qx + (k & 1) + 0.5, y = qy + (k >> 1) + 0.5;
        const double side = (x1 - x0) * (y - y0) - (y1 - y0) * (x - x0);
        nearest = std::min(nearest, std::abs(side) / std::hypot(x1 - x0, y1 - y0));
        (side > 0 ? above : below) = true;
      }
      if (above && below) ++split;
    }
  }
  ASSERT_GT(nearest, 0.01) << "a pixel centre on the diagonal: the derivation would be ambiguous";
  const uint64_t pixels = uint64_t(kExtent.width) * kExtent.height;
  const double want = 4.0 * double(pixels / 4 + split) / double(pixels);
  std::printf("  full-screen rectangle: %" PRIu64 " split quads, predicted %.4f, %s %.4f\n", split, want,
              r.density["quad"]["source"].get<std::string>().c_str(), quadOvershading(r.density));
  EXPECT_EQ(r.density.at("covered_pixels").get<uint64_t>(), pixels);
  // Tolerance: 4 quads (16 lanes) either way, for a rasteriser that
  // launches a quad for a block a triangle touches without a covered centre.
  EXPECT_NEAR(quadOvershading(r.density), want, 16.0 / double(pixels));
  EXPECT_NEAR(r.density["cpu_estimate"]["quad_overshading"].get<double>(), want, 1e-12);
  EXPECT_LT(want, 1.1);
}

TEST(Density, QuadOvershadingOfPixelSizedTrianglesIsFour) {
  // 1 x 1 px cells (two triangles of 0.5 px^2, sub-pixel) over 112 x 56 px:
  // each cell holds one pixel centre, 0.4 px right of and 0.15 px below its
  // corner, so one triangle covers it, alone in its quad: 1 live + 3 helper lanes.
  DensityRun r = renderGrids({{8.1, 8.35, 112, 56, 1.0, 1.0}});
  ASSERT_TRUE(r.ok);
  const uint64_t covered = 112 * 56;
  EXPECT_EQ(r.density.at("sub_pixel").get<uint64_t>(), 2 * covered);
  EXPECT_EQ(r.density.at("covered_pixels").get<uint64_t>(), covered);
  EXPECT_EQ(r.density.at("pixels").at("sub_pixel").get<uint64_t>(), covered);
  // Predicted 4: within 1% (a device that packs two triangles into one quad would fall below).
  EXPECT_NEAR(quadOvershading(r.density), 4.0, 0.04);
  EXPECT_DOUBLE_EQ(r.density["cpu_estimate"]["quad_overshading"].get<double>(), 4.0);
  if (r.density["quad"]["source"] == "gpu_quad_ops") {
    EXPECT_EQ(r.density["quad"]["helper_lanes"].get<uint64_t>(), 3 * covered);
  }
}

TEST(Density, OptionTakenByForwardOnly) {
  for (const char* renderer : {"forward", "forward-zprepass"}) {
    auto good = canonicalOptions(renderer, {{"output", "density"}});
    ASSERT_TRUE(good.ok()) << good.error();
    EXPECT_EQ(variantLabel(renderer, *good), std::string(renderer) + " output=density");
    RendererOptions o;
    applyOptions(*good, o);
    EXPECT_EQ(o.forwardOutput, ForwardOutput::Density);
  }
  for (const char* renderer : {"deferred", "visbuffer", "visbuffer-lean"}) {
    auto bad = canonicalOptions(renderer, {{"output", "density"}});
    ASSERT_FALSE(bad.ok()) << renderer;
    EXPECT_EQ(bad.error().rfind(std::string("output: ") + renderer + " takes no option output", 0), 0u) << bad.error();
  }
  auto bad = canonicalOptions("forward", {{"output", "densities"}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error(), "output: \"densities\" is not one of shaded, overdraw, overshading, density");
}

}  // namespace
}  // namespace tally::renderers
