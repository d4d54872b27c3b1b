// The id-capacity sweep: spec errors name the field; the aliasing a refusal
// prevents, against a brute-force packing of every triangle; the CPU
// coverage against the tile layout worked out by hand; the id check can
// fail (a wrong decode, one corrupted id); and on lavapipe, the visibility
// buffers render up to the limits with every id naming the triangle that
// covers its pixel, and refuse one past them naming the limit and the count.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <unistd.h>
#include <nlohmann/json.hpp>

#include "sweeps/id.hpp"
#include "sweeps/sweep.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/renderer.hpp"
#include "shared.h"
#include "sweep_fixture.hpp"

namespace tally::sweeps {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const std::vector<std::string> kRenderers = {"forward", "deferred", "visbuffer", "visbuffer-lean"};
constexpr double kMinPsnrDb = 30.0;  // as renderers_test.cpp: agreement with forward

std::string errorOf(const json& spec) {
  auto parsed = parseSweepSpec(spec, kRenderers);
  return parsed ? "(no error)" : parsed.error();
}

json idSpec(const json& draws, const json& triangles) {
  return {{"sweep", "id-capacity"}, {"draws", draws}, {"triangles_per_draw", triangles}};
}

json sweep(const json& spec) { return fixture::runSpec(spec); }

TEST(IdSweepSpec, Defaults) {
  auto parsed = parseSweepSpec(idSpec({511, 512, 513}, {2}), kRenderers);
  ASSERT_TRUE(parsed.ok()) << parsed.error();
  const auto& spec = std::get<IdSweepSpec>(*parsed);
  EXPECT_EQ(spec.renderers, (std::vector<std::string>{"visbuffer", "visbuffer-lean"}));
  EXPECT_EQ(spec.draws, (std::vector<uint64_t>{511, 512, 513}));
  EXPECT_EQ(spec.trianglesPerDraw, (std::vector<uint64_t>{2}));
  EXPECT_EQ(spec.wrongPixels, 0u);
  // The default resolution holds a tile for every draw up to 1024.
  EXPECT_GE(uint64_t(spec.resolution.width / kIdTileWidth) * (spec.resolution.height / kIdTileHeight), 1024u);
}

TEST(IdSweepSpec, BadSpecsNameTheField) {
  auto with = [](json extra) {
    json spec = idSpec({1, 2}, {2});
    for (auto& [k, v] : extra.items()) spec[k] = v;
    return errorOf(spec);
  };
  auto startsWith = [](const std::string& error, const std::string& prefix) {
    return ::testing::AssertionResult(error.rfind(prefix, 0) == 0) << error;
  };
  EXPECT_EQ(with(json::object()), "(no error)");
  EXPECT_TRUE(startsWith(with({{"frames", 2}}), "frames: unknown field"));
  EXPECT_TRUE(
      startsWith(with({{"renderers", {"forward"}}}), "renderers[0]: 'forward' writes no visibility id"));
  EXPECT_TRUE(
      startsWith(with({{"renderers", {"visbuffer", "nope"}}}), "renderers[1]: unknown renderer 'nope'"));
  EXPECT_TRUE(startsWith(with({{"renderers", {"visbuffer", "visbuffer"}}}),
                         "renderers[1]: 'visbuffer' listed twice"));
  EXPECT_TRUE(startsWith(with({{"renderers", json::array()}}), "renderers: must be an array"));
  EXPECT_TRUE(startsWith(with({{"draws", {1, 0}}}), "draws[1]: must be an integer from 1 to 4096"));
  EXPECT_TRUE(startsWith(with({{"draws", {2, 2}}}), "draws[1]: 2 listed twice"));
  EXPECT_TRUE(startsWith(with({{"draws", {1.5}}}), "draws[0]: must be an integer"));
  EXPECT_TRUE(startsWith(with({{"draws", json::array()}}), "draws: must be an array of 1 to 16"));
  EXPECT_TRUE(
      startsWith(with({{"triangles_per_draw", {"many"}}}), "triangles_per_draw[0]: must be an integer"));
  EXPECT_TRUE(
      startsWith(with({{"resolution", {3, 64}}}), "resolution[0]: must be an integer from 4 (one tile)"));
  EXPECT_TRUE(startsWith(with({{"resolution", {64}}}), "resolution: must be [width, height]"));
  EXPECT_TRUE(
      startsWith(with({{"threshold", {{"relative", 0.1}}}}), "threshold: must be {\"wrong_pixels\": n}"));
  EXPECT_TRUE(startsWith(with({{"threshold", {{"wrong_pixels", -1}}}}),
                         "threshold.wrong_pixels: must be an integer"));
  EXPECT_TRUE(
      startsWith(errorOf({{"sweep", "id-capacity"}, {"triangles_per_draw", {2}}}), "draws: required"));
  EXPECT_TRUE(
      startsWith(errorOf({{"sweep", "id-capacity"}, {"draws", {2}}}), "triangles_per_draw: required"));
  // Every point is built: 1024 draws of 2^23 triangles would be 2^33.
  const std::string big = errorOf(idSpec({1, 1024}, {2, 8388608}));
  EXPECT_TRUE(startsWith(big, "triangles_per_draw: draws 1024 x triangles_per_draw 8388608"));
  EXPECT_NE(big.find(std::to_string(kMaxIdSweepTriangles)), std::string::npos) << big;
  EXPECT_EQ(errorOf(idSpec({1, 2}, {2, 8388608})), "(no error)");  // exactly the budget
}

// Every id of `draws` x `triangles` packed as packVisibilityId does, sorted:
// how many triangles share their id with another, or hold the clear value.
uint64_t bruteForceShared(uint64_t draws, uint64_t triangles) {
  std::vector<uint32_t> ids;
  ids.reserve(draws * triangles);
  for (uint64_t d = 0; d < draws; ++d) {
    for (uint64_t t = 0; t < triangles; ++t)
      ids.push_back(shaders::packVisibilityId(uint32_t(d), uint32_t(t)));
  }
  std::sort(ids.begin(), ids.end());
  uint64_t shared = 0;
  for (size_t i = 0; i < ids.size();) {
    size_t j = i;
    while (j < ids.size() && ids[j] == ids[i]) ++j;
    if (j - i > 1 || ids[i] == shaders::kVisibilityClear) shared += j - i;
    i = j;
  }
  return shared;
}

TEST(IdSweepAlias, MatchesEveryIdPackedAnyway) {
  for (auto [draws, triangles] : std::vector<std::pair<uint64_t, uint64_t>>{
           {513, 2}, {1030, 3}, {512, 4}, {1, (1u << 23) + 5}, {3, 1u << 23}}) {
    SCOPED_TRACE(std::to_string(draws) + " x " + std::to_string(triangles));
    json alias = wouldAlias(draws, triangles);
    EXPECT_EQ(alias["triangles_sharing_an_id"], bruteForceShared(draws, triangles));
  }
  // 513 draws: draw 512 wraps to draw 0 (the draw id shifted out of 32 bits).
  json a = wouldAlias(513, 2);
  EXPECT_EQ(a["draws_sharing_a_draw_id"], 2);
  EXPECT_EQ(a["last_triangle"]["decoded_draw"], 0);
  // 2^23 triangles in one draw: ids 0 .. 2^23 - 1 are all distinct, so a
  // single draw loses nothing; the per-draw limit is uniform because draw
  // 511's last triangle would be the clear value (checked by analysis: only
  // (511, 2^23 - 1) packs to all ones).
  json one = wouldAlias(1, 1u << 23);
  EXPECT_EQ(one["triangles_sharing_an_id"], 0);
  json full = wouldAlias(512, 1u << 23);
  EXPECT_EQ(full["triangles_read_as_clear"], 1);
  EXPECT_EQ(full["triangles_sharing_an_id"], 1);
  EXPECT_EQ(full["last_triangle"]["clear"], true);
  json over = wouldAlias(1, (1u << 23) + 5);
  EXPECT_EQ(over["triangles_sharing_a_triangle_id_per_draw"], 10);  // 0..4 with 2^23..2^23 + 4
}

// The tile layout by hand: every visible triangle is half a 2 x 3 strip and
// holds 3 pixel centres; no centre lies on an edge.
TEST(IdSweepCoverage, EveryVisibleTriangleHoldsThreeCentres) {
  const VkExtent2D extent = {16, 9};  // 4 x 3 tiles
  for (auto [draws, triangles] : std::vector<std::pair<uint64_t, uint64_t>>{{5, 6}, {12, 1}, {40, 9}}) {
    SCOPED_TRACE(std::to_string(draws) + " x " + std::to_string(triangles));
    IdScene s = buildIdScene(draws, triangles, extent);
    EXPECT_EQ(s.tiledDraws, std::min<uint64_t>(draws, 12));
    EXPECT_EQ(s.visiblePerDraw, std::min<uint64_t>(triangles, 4));
    IdCoverage c = idCoverage(s.scene, s.camera, extent);
    std::map<std::pair<uint32_t, uint32_t>, int> centres;
    for (size_t i = 0; i < c.draw.size(); ++i) {
      EXPECT_FALSE(c.ambiguous[i]) << "pixel " << i;
      if (c.draw[i] != IdCoverage::kNone) ++centres[{c.draw[i], c.triangle[i]}];
    }
    EXPECT_EQ(centres.size(), s.tiledDraws * s.visiblePerDraw);
    for (const auto& [which, count] : centres) {
      EXPECT_EQ(count, 3) << "draw " << which.first << " triangle " << which.second;
      EXPECT_GE(which.second, triangles - s.visiblePerDraw);  // only the last triangles are drawn
    }
    if (draws > 12) {  // too few tiles: draw 0 and the highest 11
      EXPECT_TRUE(centres.count({0, uint32_t(triangles - 1)}));
      EXPECT_TRUE(centres.count({uint32_t(draws - 11), uint32_t(triangles - 1)}));
      EXPECT_FALSE(centres.count({uint32_t(draws - 12), uint32_t(triangles - 1)}));
    }
  }
}

// Renders one point with `renderer` and returns its ids (empty on failure).
struct Rendered {
  IdScene scene;
  IdCoverage truth;
  std::vector<uint32_t> ids;
};
Rendered renderIds(gpu::Context& ctx, const std::string& renderer, uint64_t draws, uint64_t triangles,
                   VkExtent2D extent) {
  Rendered out{buildIdScene(draws, triangles, extent), {}, {}};
  out.truth = idCoverage(out.scene.scene, out.scene.camera, extent);
  renderers::GpuScene gpuScene;
  auto uploaded = gpuScene.upload(ctx, out.scene.scene);
  EXPECT_TRUE(uploaded.ok()) << uploaded.error();
  auto made = renderers::makeRenderer(renderer);
  EXPECT_TRUE(made.ok());
  if (!uploaded || !made) return out;
  renderers::RendererOptions ro{extent, false, spirv::Mode{}, 0, {0.5f, 8.0f}};
  auto ok = (*made)->setup(ctx, gpuScene, ro);
  EXPECT_TRUE(ok.ok()) << ok.error();
  if (!ok) return out;
  (*made)->renderFrame(out.scene.camera);
  out.ids = idsOf((*made)->targetBytes("visibility.id"), uint64_t{extent.width} * extent.height);
  (*made)->destroy();
  gpuScene.destroy();
  return out;
}

// The check is not vacuous: decoded one bit off, or with one id changed, the
// same frame shows wrong pixels, as many as the analysis predicts.
TEST(IdSweepCheck, AWrongDecodeOrACorruptIdIsCaught) {
  const VkExtent2D extent = {66, 48};  // 16 x 16 tiles (256 draws) and two columns of background
  auto result = gpu::withDevice("", [&](gpu::Context& ctx) -> Result<json> {
    for (const char* renderer : {"visbuffer", "visbuffer-lean"}) {
      SCOPED_TRACE(renderer);
      // Draws 45..299 hold tiles beside draw 0: draw ids with bit 8 set and clear.
      Rendered r = renderIds(ctx, renderer, 300, 6, extent);
      EXPECT_EQ(r.ids.size(), size_t(extent.width) * extent.height);
      if (r.ids.empty()) continue;
      IdCheck right = checkIds(r.ids, r.truth, extent);
      EXPECT_EQ(right.wrong, 0u) << right.toJson().dump();
      EXPECT_EQ(right.covered, 256u * 4 * 3);
      EXPECT_EQ(right.checked, r.ids.size());
      // 22 bits of triangle: draw d decodes as 2d (its triangles are < 2^22),
      // right only for draw 0; 24 bits: draw d as d / 2 with the triangle
      // gaining (d & 1) << 23, right only for draw 0 again.
      const uint64_t drawZero = 4 * 3;
      for (uint32_t bits : {22u, 24u}) {
        IdCheck shifted = checkIds(r.ids, r.truth, extent, IdLayout{bits});
        EXPECT_EQ(shifted.wrong, right.covered - drawZero) << bits;
        EXPECT_EQ(shifted.missing, 0u);
        EXPECT_FALSE(shifted.examples.empty());
      }
      // One id moved to its neighbour triangle, one background pixel given an id,
      // one covered pixel cleared: three wrong pixels, one of them missing.
      std::vector<uint32_t> ids = r.ids;
      auto next = [&](size_t from, bool wantCovered) {
        while (from < ids.size() && (r.truth.draw[from] != IdCoverage::kNone) != wantCovered) ++from;
        return from;
      };
      const size_t covered = next(0, true), cleared = next(covered + 1, true), background = next(0, false);
      EXPECT_LT(std::max({covered, cleared, background}), ids.size());
      if (std::max({covered, cleared, background}) >= ids.size()) continue;
      ids[covered] ^= 1u;
      ids[cleared] = kIdClear;
      ids[background] = shaders::packVisibilityId(0, 0);
      IdCheck corrupt = checkIds(ids, r.truth, extent);
      EXPECT_EQ(corrupt.wrong, 3u);
      EXPECT_EQ(corrupt.missing, 1u);
    }
    return json::object();
  });
  ASSERT_TRUE(result.ok()) << result.error();
}

// The value at a dotted path into a point ("error.wrong_pixels"), or null.
json at(const json& point, const std::string& dotted) {
  json v = point;
  std::stringstream parts(dotted);
  for (std::string key; std::getline(parts, key, '.');) {
    if (!v.is_object() || !v.contains(key)) return nullptr;
    v = v[key];
  }
  return v;
}

const json& point(const json& result, const std::string& renderer, uint64_t draws, uint64_t triangles) {
  for (const auto& p : result["points"]) {
    if (p["renderer"] == renderer && p["draws"] == draws && p["triangles_per_draw"] == triangles) return p;
  }
  static const json none;
  ADD_FAILURE() << "no point " << renderer << " " << draws << " x " << triangles;
  return none;
}

// Every point either refused, naming the limit and the count, or rendered
// with every id naming the triangle under its pixel, and the image agreeing
// with forward's: never garbage drawn silently.
void expectRefusedOrExact(const json& result) {
  for (const auto& p : result["points"]) {
    SCOPED_TRACE(p.dump().substr(0, 400));
    EXPECT_EQ(p["status"], p["expected"]);
    if (p["status"] == "refused") {
      EXPECT_TRUE(p["refusal"]["names_limit"].get<bool>());
      EXPECT_TRUE(p["refusal"]["names_count"].get<bool>());
      EXPECT_EQ(p["refusal"]["message"].get<std::string>().rfind(p["renderer"].get<std::string>(), 0), 0u);
      EXPECT_TRUE(p.contains("would_alias"));
      EXPECT_EQ(p["refused"], 1);
    } else {
      ASSERT_EQ(p["status"], "rendered");
      EXPECT_EQ(p["refused"], 0);
      EXPECT_EQ(p["error"]["wrong_pixels"], 0);
      EXPECT_EQ(p["error"]["missing_pixels"], 0);
      EXPECT_EQ(p["error"]["ambiguous_pixels"], 0);
      EXPECT_EQ(p["error"]["checked_pixels"],
                result["resolution"][0].get<uint64_t>() * result["resolution"][1].get<uint64_t>());
      // Ids are on screen: every tiled draw's visible triangles, 3 centres each.
      EXPECT_EQ(p["error"]["covered_pixels"],
                p["tiled_draws"].get<uint64_t>() * p["visible_triangles_per_draw"].get<uint64_t>() * 3);
      const auto& image = p["image_error"];
      EXPECT_TRUE(image["identical"].get<bool>() || image["psnr"].get<double>() >= kMinPsnrDb)
          << image.dump();
    }
  }
}

TEST(IdSweep, DrawAxisRendersUpTo512AndRefuses513) {
  json result = sweep(idSpec({511, 512, 513}, {4}));
  ASSERT_FALSE(result.is_null());
  EXPECT_EQ(result["sweep"], "id-capacity");
  EXPECT_EQ(result["parameters"], json({"draws", "triangles_per_draw"}));
  EXPECT_EQ(result["capacity"]["draws"], 512);
  EXPECT_EQ(result["capacity"]["triangles_per_draw"], 8388607);
  ASSERT_EQ(result["points"].size(), 6u);
  expectRefusedOrExact(result);
  for (const char* renderer : {"visbuffer", "visbuffer-lean"}) {
    SCOPED_TRACE(renderer);
    for (uint64_t draws : {511u, 512u}) {
      const json& p = point(result, renderer, draws, 4);
      EXPECT_EQ(p["status"], "rendered");
      EXPECT_EQ(p["tiled_draws"], draws);  // every draw on screen, up to draw id 511
      EXPECT_EQ(p["error"]["highest_right"], json({{"draw", draws - 1}, {"triangle", 3}}));
    }
    const json& refused = point(result, renderer, 513, 4);
    ASSERT_EQ(refused["status"], "refused");
    const std::string message = refused["refusal"]["message"];
    EXPECT_NE(message.find("513"), std::string::npos) << message;
    EXPECT_NE(message.find("512"), std::string::npos) << message;
    EXPECT_EQ(refused["would_alias"]["draws_sharing_a_draw_id"], 2);  // 512 wraps onto 0
  }
  // Per renderer: draws fail at 513; along triangles, only the 513-draw group fails.
  ASSERT_FALSE(result["fails_at"].is_null());
  EXPECT_EQ(result["fails_at"]["draws"],
            json({{{"renderer", "visbuffer"}, {"triangles_per_draw", 4}, {"draws", 513}},
                  {{"renderer", "visbuffer-lean"}, {"triangles_per_draw", 4}, {"draws", 513}}}));
  for (const auto& g : result["fails_at"]["triangles_per_draw"]) {
    EXPECT_EQ(g["triangles_per_draw"], g["draws"] == 513 ? json(4) : json(nullptr)) << g.dump();
  }
  // Plots name fields every point has: x and y numbers, the series present.
  ASSERT_EQ(result["plots"].size(), 4u);
  for (const auto& plot : result["plots"]) {
    SCOPED_TRACE(plot.dump());
    for (const auto& p : result["points"]) {
      EXPECT_TRUE(at(p, plot["x"]).is_number());
      EXPECT_TRUE(at(p, plot["y"]).is_number());
      for (const auto& s : plot["series"]) EXPECT_FALSE(at(p, s).is_null());
    }
  }
}

// The per-draw limit itself: 8,388,607 triangles render with their top ids
// (8,388,603 .. 8,388,606) on screen and right; one more is refused. One
// draw of 8,388,608 would lose no id (ids 0 .. 2^23 - 1 are distinct); the
// limit is per draw so that draw 511's last id is never the clear value.
TEST(IdSweep, TriangleAxisRendersTheTopIdsAndRefusesOneMore) {
  const uint64_t limit = shaders::kTriangleIdMask;
  json result = sweep(idSpec({1}, {limit, limit + 1}));
  ASSERT_FALSE(result.is_null());
  ASSERT_EQ(result["points"].size(), 4u);
  expectRefusedOrExact(result);
  for (const char* renderer : {"visbuffer", "visbuffer-lean"}) {
    SCOPED_TRACE(renderer);
    const json& top = point(result, renderer, 1, limit);
    ASSERT_EQ(top["status"], "rendered");
    EXPECT_EQ(top["error"]["covered_pixels"], 4 * 3);
    EXPECT_EQ(top["error"]["highest_right"], json({{"draw", 0}, {"triangle", limit - 1}}));
    const json& over = point(result, renderer, 1, limit + 1);
    ASSERT_EQ(over["status"], "refused");
    const std::string message = over["refusal"]["message"];
    EXPECT_NE(message.find("8388608"), std::string::npos) << message;
    EXPECT_NE(message.find("8388607"), std::string::npos) << message;
    EXPECT_EQ(over["would_alias"]["triangles_sharing_an_id"], 0);
  }
  EXPECT_EQ(result["fails_at"]["triangles_per_draw"],
            json({{{"renderer", "visbuffer"}, {"draws", 1}, {"triangles_per_draw", limit + 1}},
                  {{"renderer", "visbuffer-lean"}, {"draws", 1}, {"triangles_per_draw", limit + 1}}}));
  for (const auto& g : result["fails_at"]["draws"]) {
    EXPECT_EQ(g["draws"], g["triangles_per_draw"] == limit ? json(nullptr) : json(1)) << g.dump();
  }
}

// `tallyd capture --spec` routes the sweep and names a bad field.
TEST(IdSweep, TallydRunsItAndNamesBadFields) {
  const fs::path dir = fs::temp_directory_path() / ("tally-id-sweep-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto capture = [&](const json& spec) {
    std::ofstream(dir / "spec.json") << spec.dump();
    std::string cmd = std::string(TALLYD_PATH) + " capture --quiet --spec " + (dir / "spec.json").string() +
                      " --out " + (dir / "result.json").string() + " 2>" + (dir / "err").string();
    return WEXITSTATUS(std::system(cmd.c_str()));
  };
  auto slurp = [&](const std::string& name) {
    std::ifstream in(dir / name);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  };
  json spec = idSpec({2}, {2});
  spec["renderers"] = {"visbuffer-lean"};
  ASSERT_EQ(capture(spec), 0) << slurp("err");
  json result = json::parse(slurp("result.json"));
  EXPECT_EQ(result["sweep"], "id-capacity");
  EXPECT_EQ(result["spec"], spec);
  ASSERT_EQ(result["points"].size(), 1u);
  EXPECT_EQ(result["points"][0]["status"], "rendered");
  EXPECT_TRUE(result["fails_at"].is_null());

  spec["renderers"] = {"deferred"};
  EXPECT_EQ(capture(spec), 1);
  EXPECT_NE(slurp("err").find("renderers[0]: 'deferred' writes no visibility id"), std::string::npos)
      << slurp("err");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace tally::sweeps
