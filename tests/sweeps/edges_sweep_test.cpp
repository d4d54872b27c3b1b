// The material-edges sweep: its spec (each bad field named), the mask
// fractions of the cell layout derived by hand, the renderers' material
// selection options on lavapipe ("uniform" refused without descriptor
// indexing, naming the feature), and the sweep itself: the reference against
// itself and first-lane over identical textures are exact; with distinct
// textures every wrong pixel lies in a subgroup-sized block that the
// reference image shows to hold two materials, the wrong fraction grows as
// cells shrink and is 0 for cells aligned to that block; fails_at follows
// from the points.
#include <algorithm>
#include <set>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "sweeps/sweep.hpp"
#include "sweep_fixture.hpp"
#include "gpu/context.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/visbuffer_base.hpp"

namespace tally::sweeps {
namespace {

using nlohmann::json;
using renderers::MaterialSelection;

const std::vector<std::string> kRenderers = {"forward", "deferred", "visbuffer", "visbuffer-lean"};

std::string errorOf(const json& spec) {
  auto parsed = parseSweepSpec(spec, kRenderers);
  return parsed ? "(no error)" : parsed.error();
}

json base() {
  return {{"sweep", "material-edges"},
          {"cell_sizes", {16, 4, 1}},
          {"threshold", {{"boundary_error_fraction", 0.01}}}};
}

json with(const std::string& key, const json& value) {
  json spec = base();
  spec[key] = value;
  return spec;
}

TEST(EdgesSweepSpec, DefaultsAndFields) {
  auto parsed = parseSweepSpec(base(), kRenderers);
  ASSERT_TRUE(parsed.ok()) << parsed.error();
  const auto& spec = std::get<EdgesSweepSpec>(*parsed);
  EXPECT_EQ(spec.renderer, "visbuffer");
  EXPECT_TRUE(spec.selections.empty());  // those the device supports
  EXPECT_EQ(spec.cellSizes, (std::vector<uint32_t>{16, 4, 1}));
  EXPECT_EQ(spec.materials, 4u);
  EXPECT_EQ(spec.resolution.width, 96u);
  EXPECT_EQ(spec.resolution.height, 64u);
  EXPECT_FALSE(spec.sameTexture);
  EXPECT_DOUBLE_EQ(spec.threshold, 0.01);

  json full = base();
  full["renderer"] = "visbuffer-lean";
  full["selections"] = {"uniform", "first-lane", "nonuniform"};
  full["materials"] = 16;
  full["resolution"] = {32, 8};
  full["same_texture"] = true;
  auto all = parseSweepSpec(full, kRenderers);
  ASSERT_TRUE(all.ok()) << all.error();
  const auto& s = std::get<EdgesSweepSpec>(*all);
  EXPECT_EQ(s.renderer, "visbuffer-lean");
  EXPECT_EQ(s.selections,
            (std::vector<MaterialSelection>{MaterialSelection::Uniform, MaterialSelection::FirstLane,
                                            MaterialSelection::NonUniform}));
  EXPECT_EQ(s.materials, 16u);
  EXPECT_EQ(s.resolution.width, 32u);
  EXPECT_TRUE(s.sameTexture);
}

TEST(EdgesSweepSpec, BadSpecsNameTheField) {
  auto startsWith = [](const json& spec, const std::string& prefix) {
    std::string e = errorOf(spec);
    EXPECT_TRUE(e.starts_with(prefix)) << "got: " << e << "\nexpected: " << prefix;
  };
  startsWith(with("frames", 2), "frames: unknown field");
  startsWith(with("renderer", "forward"), "renderer: 'forward' binds material maps per draw");
  startsWith(with("renderer", "nope"), "renderer: unknown renderer 'nope'");
  startsWith(with("renderer", 3), "renderer: must be a renderer name");
  startsWith(with("selections", json::array()), "selections: must be a non-empty array");
  startsWith(with("selections", {"first-lane", "bogus"}), "selections[1]: must be \"first-lane\"");
  startsWith(with("selections", {"uniform", "uniform"}), "selections[1]: \"uniform\" listed twice");
  startsWith(with("materials", 1), "materials: must be an integer from 2 to 16");
  startsWith(with("materials", 17), "materials: must be an integer from 2 to 16");
  startsWith(with("materials", 2.5), "materials: must be an integer");
  startsWith(with("same_texture", "yes"), "same_texture: must be true or false");
  startsWith(with("resolution", {96}), "resolution: must be [width, height]");
  startsWith(with("resolution", {96, 0}), "resolution[1]: must be an integer from 1 to");
  startsWith(with("cell_sizes", json::array()), "cell_sizes: must be an array of 1 to");
  startsWith(with("cell_sizes", {4, 0}), "cell_sizes[1]: must be a whole number of pixels from 1 to");
  startsWith(with("cell_sizes", {1.5}), "cell_sizes[0]: must be a whole number of pixels");
  startsWith(with("cell_sizes", {4, 4}), "cell_sizes[1]: 4 listed twice");
  // 1-pixel cells at 1024x1024 are (1024 + 2)^2 cells, beyond 2^18.
  json big = with("resolution", {1024, 1024});
  big["cell_sizes"] = {64, 1};
  startsWith(big, "cell_sizes[1]: cells of 1 pixels at 1024x1024 are 1052676 cells, more than the limit");
  json noCells = base();
  noCells.erase("cell_sizes");
  startsWith(noCells, "cell_sizes: required");
  json noThreshold = base();
  noThreshold.erase("threshold");
  startsWith(noThreshold, "threshold: required");
  startsWith(with("threshold", {{"relative", 0.1}}), "threshold: must be {\"boundary_error_fraction\": x}");
  startsWith(with("threshold", {{"boundary_error_fraction", 0}}),
             "threshold.boundary_error_fraction: must be a number in (0, 1]");
  startsWith(with("threshold", {{"boundary_error_fraction", 1.5}}),
             "threshold.boundary_error_fraction: must be");
}

// The layout's mask fractions, derived by hand. Aligned 2-pixel quads and
// cells of s from the same origin: an even s puts every cell edge on a quad
// edge (no quad straddles one); an odd s puts every other edge (the odd
// multiples of s) inside a quad, one quad column of 2 per 2s pixels, so 1/s
// of the columns (and rows); a pixel is in a mixed quad when its column or its
// row is: 1 - (1 - 1/s)^2.
TEST(EdgesSweepSpec, BlockFractionsOfTheLayout) {
  for (uint32_t s : {1u, 3u, 5u, 7u, 9u}) {
    double perAxis = 1.0 / s;
    EXPECT_NEAR(edgeBlockFraction(s, 2), 1.0 - (1.0 - perAxis) * (1.0 - perAxis), 1e-12) << s;
  }
  for (uint32_t s : {2u, 4u, 6u, 16u}) EXPECT_EQ(edgeBlockFraction(s, 2), 0.0) << s;
  // 4-pixel blocks: cells of 4k never straddle; 2-pixel cells put an edge in
  // every block; 8-pixel cells: none.
  EXPECT_EQ(edgeBlockFraction(4, 4), 0.0);
  EXPECT_EQ(edgeBlockFraction(8, 4), 0.0);
  EXPECT_EQ(edgeBlockFraction(2, 4), 1.0);
  EXPECT_EQ(edgeBlockFraction(1, 4), 1.0);
  // 6-pixel cells, 4-pixel blocks, period 12: blocks [0,4) [4,8) [8,12) with
  // the edge at 6 inside the second only: 1/3 per axis.
  EXPECT_NEAR(edgeBlockFraction(6, 4), 1.0 - (2.0 / 3.0) * (2.0 / 3.0), 1e-12);
  // The block that holds a subgroup: side^2 >= lanes, a power of two, >= 2.
  EXPECT_EQ(subgroupBlockSide(1), 2u);
  EXPECT_EQ(subgroupBlockSide(4), 2u);
  EXPECT_EQ(subgroupBlockSide(8), 4u);
  EXPECT_EQ(subgroupBlockSide(16), 4u);
  EXPECT_EQ(subgroupBlockSide(32), 8u);
  EXPECT_EQ(subgroupBlockSide(64), 8u);
  // Neighbouring cells always differ, diagonal ones too from 3 materials on.
  for (uint32_t n : {2u, 3u, 4u, 16u}) {
    for (int64_t j = -2; j < 6; ++j) {
      for (int64_t i = -2; i < 6; ++i) {
        uint32_t m = edgeMaterialAt(i * 4, j * 4, 4, n);
        EXPECT_LT(m, n);
        EXPECT_NE(m, edgeMaterialAt((i + 1) * 4, j * 4, 4, n));
        EXPECT_NE(m, edgeMaterialAt(i * 4, (j + 1) * 4, 4, n));
        if (n >= 4) {
          EXPECT_NE(m, edgeMaterialAt((i + 1) * 4, (j + 1) * 4, 4, n));
        }
      }
    }
  }
}

// One device for the renderer-level tests.
class EdgesDevice : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto ctx = gpu::createContext({});
    ASSERT_TRUE(ctx.ok()) << ctx.error();
    ctx_ = new gpu::Context(std::move(ctx).value());
  }
  static void TearDownTestSuite() {
    if (ctx_ != nullptr) gpu::destroyContext(*ctx_);
    delete ctx_;
    ctx_ = nullptr;
  }

  struct Frame {
    std::vector<uint8_t> image;
    json notes;
  };
  static Result<Frame> render(const renderers::GpuScene& scene, const std::string& renderer,
                              MaterialSelection selection, VkExtent2D extent, bool instrumented = false) {
    auto made = renderers::makeRenderer(renderer);
    if (!made) return makeError(made.error());
    renderers::RendererOptions options;
    options.extent = extent;
    options.instrumented = instrumented;
    options.lights = 0;
    options.materialSelection = selection;
    auto ok = (*made)->setup(*ctx_, scene, options);
    if (!ok) return makeError(ok.error());
    (*made)->renderFrame(edgeCamera());
    Frame f{(*made)->finalImage(), (*made)->notes()};
    (*made)->destroy();
    return f;
  }

  static gpu::Context* ctx_;
};

gpu::Context* EdgesDevice::ctx_ = nullptr;

TEST_F(EdgesDevice, UniformNeedsDescriptorIndexing) {
  if (ctx_->descriptorIndexing) GTEST_SKIP() << "this device has descriptor indexing: 'uniform' runs here";
  EdgesSweepSpec spec;
  spec.resolution = {16, 8};
  renderers::GpuScene scene;
  ASSERT_TRUE(scene.upload(*ctx_, edgeScene(spec, 4)).ok());
  const std::string reason =
      "material selection 'uniform' needs descriptor indexing (shaderSampledImageArrayNonUniformIndexing), "
      "which this device lacks";
  for (std::string renderer : {"visbuffer", "visbuffer-lean"}) {
    auto frame = render(scene, renderer, MaterialSelection::Uniform, {16, 8});
    ASSERT_FALSE(frame.ok());
    EXPECT_EQ(frame.error(), renderer + ": " + reason);
  }
  scene.destroy();

  // Asked for in a sweep: refused naming the entry; by default: left out, with the reason.
  json asked = with("selections", {"first-lane", "uniform"});
  asked["resolution"] = {16, 8};
  auto parsed = parseSweepSpec(asked, renderers::rendererNames());
  ASSERT_TRUE(parsed.ok()) << parsed.error();
  auto refused = fixture::run(*parsed);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error(), "selections[1]: " + reason);

  json byDefault = with("resolution", {16, 8});
  byDefault["cell_sizes"] = {4};
  auto defaults = parseSweepSpec(byDefault, renderers::rendererNames());
  ASSERT_TRUE(defaults.ok()) << defaults.error();
  auto result = fixture::run(*defaults);
  ASSERT_TRUE(result.ok()) << result.error();
  EXPECT_EQ((*result)["selections_skipped"], json({reason}));
  for (const auto& s : (*result)["selections"]) EXPECT_NE(s, "uniform");
}

TEST_F(EdgesDevice, SelectionIsInTheNotesAndCompilesInstrumented) {
  if (auto why = renderers::materialSelectionUnsupported(*ctx_, MaterialSelection::FirstLane); !why.empty()) {
    GTEST_SKIP() << why;
  }
  EdgesSweepSpec spec;
  spec.resolution = {16, 8};
  renderers::GpuScene scene;
  ASSERT_TRUE(scene.upload(*ctx_, edgeScene(spec, 4)).ok());
  for (std::string renderer : {"visbuffer", "visbuffer-lean"}) {
    auto reference = render(scene, renderer, MaterialSelection::NonUniform, {16, 8});
    ASSERT_TRUE(reference.ok()) << reference.error();
    EXPECT_EQ(reference->notes["material_selection"], "nonuniform");
    // Counters around subgroupBroadcastFirst: the instrumented twin sets up and draws the same picture.
    auto counted = render(scene, renderer, MaterialSelection::FirstLane, {16, 8}, true);
    ASSERT_TRUE(counted.ok()) << counted.error();
    EXPECT_EQ(counted->notes["material_selection"], "first-lane");
    auto plain = render(scene, renderer, MaterialSelection::FirstLane, {16, 8});
    ASSERT_TRUE(plain.ok()) << plain.error();
    EXPECT_EQ(counted->image, plain->image) << renderer;
  }
  scene.destroy();
}

// Every pixel the first-lane selection gets wrong lies in an aligned block of
// the side that holds a subgroup (from the subgroup size the device reports)
// whose pixels show more than one colour in the reference image: the
// neighbourhood comes from the pictures, not from the sweep's layout code.
TEST_F(EdgesDevice, FirstLaneErrorsStayInMixedSubgroupBlocks) {
  if (auto why = renderers::materialSelectionUnsupported(*ctx_, MaterialSelection::FirstLane); !why.empty()) {
    GTEST_SKIP() << why;
  }
  uint32_t side = 2;
  while (side * side < ctx_->subgroupSize) side *= 2;
  const uint32_t width = 48, height = 32;
  EdgesSweepSpec spec;
  spec.resolution = {width, height};
  for (std::string renderer : {"visbuffer", "visbuffer-lean"}) {
    for (uint32_t cell : {3u, 2u, 1u}) {
      SCOPED_TRACE(renderer + " cell " + std::to_string(cell));
      renderers::GpuScene scene;
      ASSERT_TRUE(scene.upload(*ctx_, edgeScene(spec, cell)).ok());
      auto reference = render(scene, renderer, MaterialSelection::NonUniform, {width, height});
      auto firstLane = render(scene, renderer, MaterialSelection::FirstLane, {width, height});
      scene.destroy();
      ASSERT_TRUE(reference.ok()) << reference.error();
      ASSERT_TRUE(firstLane.ok()) << firstLane.error();
      auto colour = [&](const std::vector<uint8_t>& image, uint32_t x, uint32_t y) {
        const uint8_t* p = &image[(size_t(y) * width + x) * 4];
        return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16;
      };
      size_t wrong = 0, outside = 0;
      for (uint32_t y = 0; y < height; ++y) {
        for (uint32_t x = 0; x < width; ++x) {
          if (colour(reference->image, x, y) == colour(firstLane->image, x, y)) continue;
          ++wrong;
          std::set<uint32_t> colours;
          const uint32_t bx = x / side * side, by = y / side * side;
          for (uint32_t v = by; v < std::min(height, by + side); ++v) {
            for (uint32_t u = bx; u < std::min(width, bx + side); ++u)
              colours.insert(colour(reference->image, u, v));
          }
          if (colours.size() < 2) {
            ++outside;
            ADD_FAILURE() << "wrong pixel (" << x << ", " << y << ") in a block of one material";
          }
        }
      }
      EXPECT_GT(wrong, 0u);  // cells of 1..3 pixels always split a block of >= 2
      EXPECT_EQ(outside, 0u);

      // The sweep counts the same pixels (the same renders) and places them alike.
      json s = with("cell_sizes", {cell});
      s["renderer"] = renderer;
      s["resolution"] = {width, height};
      s["selections"] = {"first-lane"};
      auto parsed = parseSweepSpec(s, renderers::rendererNames());
      ASSERT_TRUE(parsed.ok()) << parsed.error();
      auto result = fixture::run(*parsed);
      ASSERT_TRUE(result.ok()) << result.error();
      const auto& p = (*result)["points"][0];
      EXPECT_EQ(p["wrong"]["pixels"], wrong);
      EXPECT_EQ(p["wrong"]["outside_subgroup_mask"], 0);
      EXPECT_EQ(p["wrong"]["outside_subgroup_mask_at"], json::array());
      EXPECT_EQ(p["layout_check"]["mismatched_pixels"], 0);
      EXPECT_EQ((*result)["method"]["subgroup_size"], ctx_->subgroupSize);
    }
  }
}

Result<json> sweep(const json& spec) {
  auto parsed = parseSweepSpec(spec, renderers::rendererNames());
  if (!parsed) return makeError(parsed.error());
  return fixture::run(*parsed);
}

// A dotted path into a point: "wrong.fraction".
const json* field(const json& point, const std::string& path) {
  const json* at = &point;
  size_t start = 0;
  while (start <= path.size()) {
    size_t dot = path.find('.', start);
    std::string key = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (!at->is_object() || !at->contains(key)) return nullptr;
    at = &(*at)[key];
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  return at;
}

TEST(EdgesSweep, ReferenceAgainstItselfIsExact) {
  json spec = with("selections", {"nonuniform"});
  spec["cell_sizes"] = {3, 1};
  spec["resolution"] = {32, 16};
  auto result = sweep(spec);
  ASSERT_TRUE(result.ok()) << result.error();
  ASSERT_EQ((*result)["points"].size(), 2u);
  for (const auto& p : (*result)["points"]) {
    SCOPED_TRACE(p.dump());
    EXPECT_EQ(p["selection"], "nonuniform");
    EXPECT_EQ(p["wrong"]["pixels"], 0);
    EXPECT_EQ(p["error"]["identical"], true);
    EXPECT_EQ(p["boundary_error"]["max_abs"], 0);
    EXPECT_EQ(p["layout_check"]["mismatched_pixels"], 0);
    EXPECT_EQ(p["layout_check"]["materials_sharing_a_colour"], 0);
  }
  EXPECT_TRUE((*result)["fails_at"].is_null());
}

TEST(EdgesSweep, FirstLaneOverIdenticalTexturesIsExact) {
  json spec = with("selections", {"first-lane"});
  spec["cell_sizes"] = {3, 2, 1};
  spec["resolution"] = {32, 16};
  spec["same_texture"] = true;
  auto result = sweep(spec);
  if (!result && result.error().find("subgroup") != std::string::npos) GTEST_SKIP() << result.error();
  ASSERT_TRUE(result.ok()) << result.error();
  for (const auto& p : (*result)["points"]) {
    SCOPED_TRACE(p.dump());
    // The masks still say the blocks are mixed: the selection picked other
    // maps there, and they held the same texels.
    EXPECT_GT(p["masks"]["subgroup_pixels"].get<size_t>(), 0u);
    EXPECT_EQ(p["wrong"]["pixels"], 0);
    EXPECT_EQ(p["error"]["identical"], true);
  }
  EXPECT_TRUE((*result)["fails_at"].is_null());
}

// Cells of 2n, n, n/2 ... 1 pixels with n the subgroup block side: 0 wrong
// while cells are multiples of n (no block holds two materials), then some,
// and never fewer as cells shrink. 48x24 holds whole periods of every block and cell size
// here (lcm <= 8), so the masks counted on the image equal the infinite
// plane's fractions.
TEST(EdgesSweep, WrongFractionGrowsAsCellsShrink) {
  auto probe = gpu::createContext({});
  ASSERT_TRUE(probe.ok()) << probe.error();
  const std::string unsupported =
      renderers::materialSelectionUnsupported(*probe, MaterialSelection::FirstLane);
  uint32_t side = 2;
  while (side * side < probe->subgroupSize) side *= 2;
  gpu::destroyContext(*probe);
  if (!unsupported.empty()) GTEST_SKIP() << unsupported;
  std::vector<uint32_t> cells;
  for (uint32_t c = 2 * side; c >= 1; c /= 2) cells.push_back(c);

  json spec = with("selections", {"first-lane"});
  spec["cell_sizes"] = cells;
  spec["resolution"] = {48, 24};
  spec["threshold"] = {{"boundary_error_fraction", 1e-6}};
  auto result = sweep(spec);
  ASSERT_TRUE(result.ok()) << result.error();
  const auto& points = (*result)["points"];
  ASSERT_EQ(points.size(), cells.size());
  double previous = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    const auto& p = points[i];
    SCOPED_TRACE(p.dump());
    EXPECT_EQ(p["cell_size"], cells[i]);
    EXPECT_EQ(p["pixels"], 48 * 24);
    double fraction = p["wrong"]["fraction"].get<double>();
    EXPECT_DOUBLE_EQ(fraction, p["wrong"]["pixels"].get<double>() / (48 * 24));
    if (cells[i] >= side) {
      EXPECT_EQ(p["masks"]["subgroup_pixels"], 0);
      EXPECT_EQ(fraction, 0.0);
    } else {
      // Never fewer as cells shrink; NVIDIA's 32 lanes reach 3/4 at 2-pixel
      // cells already and stay there at 1 (docs/measurement.md).
      EXPECT_GT(fraction, 0.0);
      EXPECT_GE(fraction, previous);
    }
    previous = fraction;
    EXPECT_EQ(p["wrong"]["outside_subgroup_mask"], 0);
    EXPECT_EQ(p["wrong"]["in_subgroup_mask"], p["wrong"]["pixels"]);
    size_t byDistance = 0;
    for (const auto& n : p["wrong"]["by_distance"]) byDistance += n.get<size_t>();
    EXPECT_EQ(byDistance, p["wrong"]["pixels"].get<size_t>());
    EXPECT_NEAR(p["masks"]["quad_fraction"].get<double>(), p["predicted"]["quad_fraction"].get<double>(),
                1e-12);
    EXPECT_NEAR(p["masks"]["subgroup_fraction"].get<double>(),
                p["predicted"]["subgroup_fraction"].get<double>(), 1e-12);
    // A selection can be wrong only on pixels of mixed blocks.
    EXPECT_LE(fraction, p["masks"]["subgroup_fraction"].get<double>());
  }

  // fails_at from the points: the largest cell whose fraction reaches the threshold.
  json expected = nullptr;
  for (const auto& p : points) {
    if (p["wrong"]["fraction"].get<double>() < 1e-6) continue;
    if (expected.is_null() || p["cell_size"].get<uint32_t>() > expected.get<uint32_t>())
      expected = p["cell_size"];
  }
  ASSERT_EQ(expected, side / 2);  // the first size below the block side
  EXPECT_EQ((*result)["fails_at"], json({{{"selection", "first-lane"}, {"cell_size", expected}}}));

  // Nothing reaches every pixel (the first lane is always right about itself).
  spec["threshold"] = {{"boundary_error_fraction", 1.0}};
  auto none = sweep(spec);
  ASSERT_TRUE(none.ok()) << none.error();
  EXPECT_TRUE((*none)["fails_at"].is_null());

  // Every field the plots name is in every point.
  ASSERT_EQ((*result)["plots"].size(), 2u);
  for (const auto& plot : (*result)["plots"]) {
    for (const auto& p : points) {
      EXPECT_NE(field(p, plot["x"]), nullptr) << plot["x"];
      EXPECT_NE(field(p, plot["y"]), nullptr) << plot["y"];
      for (const auto& s : plot["series"]) EXPECT_NE(field(p, s), nullptr) << s;
    }
  }
  EXPECT_EQ((*result)["plots"][0]["threshold"], 1e-6);
}

}  // namespace
}  // namespace tally::sweeps
