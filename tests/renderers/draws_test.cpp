// Counts per draw and per material (RendererOptions::draws) on the planes
// scene, whose draws are known analytically (analytic.hpp): L quads, one
// draw each, every one covering the same P pixels. Back to front every draw
// shades P fragments; front to back (and behind a depth pre-pass) only the
// nearest does. Each draw's written bytes are its fragments times what the
// pass writes per fragment, derived from the shaders (the analytic
// predictions), independently of the counts per draw; the draws sum to the
// pass's counted lines; the materials to their draws; and the lines are
// those of the same frame without draws, in exact and accumulate counting
// with footprint on.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "analytic.hpp"
#include "render_fixture.hpp"
#include "renderers/material_split.hpp"
#include "renderers/renderers.hpp"

namespace tally::renderers {
namespace {

using fixture::planes;
using fixture::render;
using fixture::Rendered;

struct Sums {
  uint64_t count = 0, bytesRead = 0, bytesWritten = 0;
  bool operator==(const Sums&) const = default;
};

Sums counterLines(const PassResult& p) {
  Sums s;
  for (const auto& a : p.accesses) {
    if (a.source != "counter") continue;
    s.count += a.count;
    (a.write ? s.bytesWritten : s.bytesRead) += a.bytes;
  }
  return s;
}

Sums drawSums(const PassResult& p) {
  Sums s;
  for (const DrawCount& d : p.draws) {
    s.count += d.count;
    s.bytesRead += d.bytesRead;
    s.bytesWritten += d.bytesWritten;
  }
  s.count += p.drawsRest.count;
  s.bytesRead += p.drawsRest.bytesRead;
  s.bytesWritten += p.drawsRest.bytesWritten;
  return s;
}

Sums materialSums(const PassResult& p) {
  Sums s;
  for (const MaterialCount& m : p.materials) {
    s.count += m.count;
    s.bytesRead += m.bytesRead;
    s.bytesWritten += m.bytesWritten;
  }
  return s;
}

void expectLinesEqual(const PassResult& with, const PassResult& without) {
  ASSERT_EQ(with.accesses.size(), without.accesses.size()) << with.name;
  for (size_t i = 0; i < with.accesses.size(); ++i) {
    const Access &a = with.accesses[i], &b = without.accesses[i];
    SCOPED_TRACE(with.name + " " + a.resource);
    EXPECT_EQ(a.resource, b.resource);
    EXPECT_EQ(a.write, b.write);
    EXPECT_EQ(a.count, b.count);
    EXPECT_EQ(a.bytes, b.bytes);
    EXPECT_EQ(a.footprintBytes, b.footprintBytes);
    EXPECT_EQ(a.footprintBlocks, b.footprintBlocks);
  }
  EXPECT_EQ(with.fragmentInvocations, without.fragmentInvocations);
}

const char* const kGeometryRenderers[] = {"forward", "forward-zprepass", "deferred", "visbuffer", "visbuffer-lean"};

// Every renderer's geometry passes, back to front and front to back: each
// draw's written bytes from its analytic fragments, the sums, and the lines
// unchanged by draws (exact and accumulate, footprint on).
TEST(RendererDraws, EachDrawWritesItsFragmentsAndTheDrawsSumToThePass) {
  const VkExtent2D extent = {61, 37};
  const uint32_t layers = 3;
  for (const char* counting : {"exact", "accumulate"}) {
    for (const char* order : {"back-to-front", "front-to-back"}) {
      const nlohmann::json spec = planes(int(layers), order, 0.5);
      const analytic::Geometry g = analytic::geometryOf(spec, extent);
      ASSERT_FALSE(g.rows.ambiguous);
      for (const char* name : kGeometryRenderers) {
        SCOPED_TRACE(std::string(name) + " " + order + " " + counting);
        auto options = [&](bool draws) {
          return [=](RendererOptions& o) {
            o.counting = spirv::parseMode(counting).value();
            o.footprintBlockBytes = 64;
            o.draws = draws;
          };
        };
        Rendered with = render(name, spec, extent, options(true));
        Rendered without = render(name, spec, extent, options(false));
        ASSERT_TRUE(with.ok && without.ok) << with.error << without.error;
        analytic::DeviceTraits device;
        device.lights = fixture::kTestLights;
        device.barycentricExtension = with.notes.value("barycentrics", "") == "extension";
        const auto predicted = analytic::predict(name, g, device);
        size_t geometryPasses = 0;
        for (size_t i = 0; i < with.frame.passes.size(); ++i) {
          const PassResult& p = with.frame.passes[i];
          expectLinesEqual(p, without.frame.passes[i]);
          EXPECT_TRUE(without.frame.passes[i].draws.empty());
          const auto prediction = std::find_if(predicted.begin(), predicted.end(),
                                               [&](const analytic::PassPrediction& q) { return q.name == p.name; });
          if (p.draws.empty()) continue;
          ++geometryPasses;
          SCOPED_TRACE(p.name);
          ASSERT_EQ(p.draws.size(), layers);
          EXPECT_EQ(p.drawsRest.draws, 0u);
          EXPECT_EQ(drawSums(p), counterLines(p));
          ASSERT_EQ(p.materials.size(), 1u);  // the planes share one material
          EXPECT_EQ(p.materials[0].draws, layers);
          EXPECT_EQ(materialSums(p), counterLines(p));
          ASSERT_NE(prediction, predicted.end());
          // What the pass writes per fragment (its counted write terms).
          uint64_t writtenPerFragment = 0;
          for (const auto& t : prediction->terms) {
            if (!t.write || t.source != "counter") continue;
            ASSERT_EQ(t.perVertex, 0u) << t.resource;
            ASSERT_NE(t.elementBytes, 0u) << t.resource;
            writtenPerFragment += t.perFragment * t.elementBytes;
          }
          // Every draw shades its P pixels, or only the nearest does (the
          // last drawn back to front, the first front to back).
          const bool all = prediction->fragments == uint64_t(layers) * g.covered;
          ASSERT_TRUE(all || prediction->fragments == g.covered) << prediction->fragments;
          const uint32_t nearest = g.backToFront ? layers - 1 : 0;
          for (uint32_t d = 0; d < layers; ++d) {
            EXPECT_EQ(p.draws[d].index, d);
            EXPECT_EQ(p.draws[d].mesh, "plane " + std::to_string(g.backToFront ? layers - 1 - d : d) + " (depth order)");
            const uint64_t fragments = all || d == nearest ? g.covered : 0;
            EXPECT_EQ(p.draws[d].bytesWritten, fragments * writtenPerFragment) << "draw " << d;
            // Every draw runs its quad's vertices, drawn or occluded.
            EXPECT_GT(p.draws[d].count, 0u) << "draw " << d;
          }
        }
        EXPECT_GE(geometryPasses, 1u);
      }
    }
  }
}

// Over the cap the draws beyond share one count: the pass's lines and the
// sums stay exact, and the rest says how many draws it holds.
TEST(RendererDraws, DrawsBeyondTheCapShareOneCount) {
  const VkExtent2D extent = {41, 23};
  const nlohmann::json spec = planes(5, "back-to-front", 1.0);
  Rendered capped = render("forward", spec, extent, [](RendererOptions& o) {
    o.draws = true;
    o.maxCountedDraws = 2;
  });
  Rendered plain = render("forward", spec, extent);
  ASSERT_TRUE(capped.ok && plain.ok);
  const PassResult& p = fixture::passNamed(capped, "forward");
  expectLinesEqual(p, fixture::passNamed(plain, "forward"));
  ASSERT_EQ(p.draws.size(), 2u);
  EXPECT_EQ(p.draws[0].index, 0u);
  EXPECT_EQ(p.draws[1].index, 1u);
  EXPECT_EQ(p.drawsRest.draws, 3u);
  EXPECT_EQ(p.drawsRest.index, 2u);
  EXPECT_EQ(drawSums(p), counterLines(p));
  EXPECT_EQ(materialSums(p), counterLines(p));
  // Back to front every draw shades the same pixels: the rest is three of them.
  EXPECT_EQ(p.drawsRest.bytesWritten, 3 * p.draws[0].bytesWritten);
  EXPECT_EQ(p.draws[0].bytesWritten, p.draws[1].bytesWritten);
  EXPECT_GT(p.draws[0].bytesWritten, 0u);
}

// Shadows on: the shadow pass draws the scene too, each draw into its own
// region, and its lines stay those of the frame without draws.
TEST(RendererDraws, TheShadowPassCountsPerDraw) {
  const VkExtent2D extent = {41, 23};
  const nlohmann::json spec = planes(3, "back-to-front", 0.5);
  for (const char* name : {"forward", "deferred"}) {
    SCOPED_TRACE(name);
    auto shadows = [](bool draws) {
      return [=](RendererOptions& o) {
        o.shadows.filter = ShadowFilter::Hard;
        o.draws = draws;
      };
    };
    Rendered with = render(name, spec, extent, shadows(true));
    Rendered without = render(name, spec, extent, shadows(false));
    ASSERT_TRUE(with.ok && without.ok) << with.error << without.error;
    const PassResult& p = fixture::passNamed(with, "shadow");
    expectLinesEqual(p, fixture::passNamed(without, "shadow"));
    ASSERT_EQ(p.draws.size(), 3u);
    EXPECT_EQ(drawSums(p), counterLines(p));
    EXPECT_EQ(materialSums(p), counterLines(p));
    for (const auto& d : p.draws) EXPECT_GT(d.count, 0u) << d.index;  // each quad's vertices, at least
  }
}

// The visibility buffers' shading passes split their material-map reads
// per material where each texture is an element of its own (descriptor
// indexing): the split sums to the pass's material-map lines. On the map
// arrays (lavapipe) a material is a layer, with no counter of its own: the
// pass has no materials, and the split is checked on the host below.
TEST(RendererDraws, ShadingPassesSplitMaterialMapReadsPerMaterial) {
  const VkExtent2D extent = {41, 23};
  const nlohmann::json spec = planes(2, "front-to-back", 0.5);
  for (const char* name : {"visbuffer", "visbuffer-lean"}) {
    for (bool compute : {false, true}) {
      SCOPED_TRACE(std::string(name) + (compute ? " compute" : " fragment"));
      Rendered r = render(name, spec, extent, [&](RendererOptions& o) {
        o.draws = true;
        o.computeShading = compute;
      });
      ASSERT_TRUE(r.ok) << r.error;
      const PassResult& shading = fixture::passNamed(r, "shading");
      EXPECT_TRUE(shading.draws.empty());
      uint64_t mapBytes = 0;
      for (const auto& a : shading.accesses)
        if (a.source == "counter" && !a.write && a.resource.rfind("material_maps.", 0) == 0) mapBytes += a.bytes;
      EXPECT_GT(mapBytes, 0u);
      const std::string path = r.notes.value("material_maps", "");
      if (path == "texture_arrays") {
        EXPECT_TRUE(shading.materials.empty());
        continue;
      }
      ASSERT_EQ(path, "descriptor_indexing");
      ASSERT_FALSE(shading.materials.empty());
      EXPECT_EQ(materialSums(shading).bytesRead, mapBytes);
      EXPECT_EQ(materialSums(shading).bytesWritten, 0u);
      bool named = false;  // the planes' one material names the entry of its own textures
      for (const auto& m : shading.materials) named = named || m.material.rfind("no ", 0) != 0;
      EXPECT_TRUE(named);
    }
  }
}

// The split on the host: each element's reads go to the materials that
// sample it (a dummy to "no <kind> map", a shared texture to one entry
// naming its materials), and every counted byte to exactly one entry.
TEST(RendererDraws, MaterialMapSplitNamesEachElementsMaterials) {
  const std::pair<int64_t, int64_t> maps = {1, 0};
  // Elements 0..4 dummies; 5: brick's own; 6: shared by brick and moss; 7: bound, unsampled.
  const std::vector<std::vector<uint32_t>> users = {{1}, {0, 1}, {0, 1}, {0, 1}, {0, 1}, {0}, {0, 1}, {}};
  const std::vector<PassCounts::Element> elements = {
      {1, 0, 0, false, 3, 12},  {1, 0, 5, false, 10, 40}, {1, 0, 6, false, 7, 28},
      {1, 0, 5, false, 1, 4},   {1, 0, 7, false, 2, 8},   {2, 0, 5, false, 100, 400},  // another binding
      {1, 0, 3, false, 0, 0}};                                                        // never reached
  const std::vector<MaterialCount> split = materialMapSplit(elements, maps, users, {"brick", "moss"}, {4, 2}, 5);
  std::map<std::string, MaterialCount> byName;
  for (const auto& m : split) byName[m.material] = m;
  ASSERT_EQ(byName.size(), 4u);
  EXPECT_EQ(byName["brick"].bytesRead, 44u);
  EXPECT_EQ(byName["brick"].count, 11u);
  EXPECT_EQ(byName["brick"].draws, 4u);
  EXPECT_EQ(byName["brick + moss"].bytesRead, 28u);
  EXPECT_EQ(byName["brick + moss"].draws, 6u);
  EXPECT_EQ(byName["no diffuse map"].bytesRead, 12u);
  EXPECT_EQ(byName["no diffuse map"].draws, 2u);
  EXPECT_EQ(byName["element 7"].bytesRead, 8u);
  EXPECT_EQ(byName["element 7"].draws, 0u);
}

// GpuScene's element users, on a scene with descriptor-indexed maps: every
// material samples exactly one element per map kind.
TEST(RendererDraws, EveryMaterialSamplesOneElementPerKind) {
  fixture::TestScene& s = fixture::testScene("atrium");
  const auto& users = s.gpu->indexedMapMaterials();
  ASSERT_FALSE(users.empty()) << "the atrium's maps fit the descriptor-indexing array";
  EXPECT_EQ(users.size(), s.gpu->indexedMapViews().size());
  std::vector<uint32_t> sampled(s.scene.materials.size(), 0);
  for (const auto& materials : users)
    for (uint32_t m : materials) ++sampled.at(m);
  for (size_t m = 0; m < sampled.size(); ++m) {
    // Five kinds; fewer elements where the material uses one texture for two kinds.
    EXPECT_GE(sampled[m], 1u) << s.scene.materials[m].name;
    EXPECT_LE(sampled[m], uint32_t(scenes::kMapSlotCount)) << s.scene.materials[m].name;
    std::set<int32_t> distinct;
    for (uint32_t k = 0; k < scenes::kMapSlotCount; ++k) {
      const int32_t t = s.scene.materials[m].maps[k];
      distinct.insert(t < 0 ? -1 - int32_t(k) : t);  // a dummy per kind, else the texture
    }
    EXPECT_EQ(sampled[m], distinct.size()) << s.scene.materials[m].name;
  }
  EXPECT_EQ(s.gpu->materialName(0), s.scene.materials[0].name.empty() ? "material 0" : s.scene.materials[0].name);
}

}  // namespace
}  // namespace tally::renderers
