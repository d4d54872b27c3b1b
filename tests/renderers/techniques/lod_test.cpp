// Levels of detail (docs/techniques.md, "Levels of detail"): the chains
// meshoptimizer builds (counts strictly decreasing, errors monotone, bounded
// analytically on a flat grid and a sphere), the level the projected-error
// formula predicts (computed here from the stored errors and the camera, not
// through the renderer's selection), the index fetches and vertex invocations
// of the geometry pass derived from the chosen levels, the image against LOD
// off, and the option table.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "strict.hpp"

#include "analysis/image.hpp"
#include "render_fixture.hpp"
#include "renderers/techniques/lod.hpp"
#include "renderers/options.hpp"
#include "scenes/mesh_builder.hpp"

namespace tally::renderers {
using namespace fixture;
namespace {

constexpr float kPi = 3.14159265358979f;

// A UV sphere of `radius` around `center`: every vertex on the sphere.
scenes::Mesh sphere(glm::vec3 center, float radius, uint32_t segments, uint32_t rings) {
  scenes::MeshBuilder b;
  std::vector<std::vector<uint32_t>> id(rings + 1, std::vector<uint32_t>(segments + 1));
  for (uint32_t r = 0; r <= rings; ++r) {
    const float theta = kPi * float(r) / float(rings);
    for (uint32_t s = 0; s <= segments; ++s) {
      const float phi = 2 * kPi * float(s) / float(segments);
      glm::vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
      id[r][s] = b.vertex(center + radius * n, n, glm::vec2(float(s) / segments, float(r) / rings));
    }
  }
  for (uint32_t r = 0; r < rings; ++r) {
    for (uint32_t s = 0; s < segments; ++s) {
      const glm::vec3 out =
          glm::normalize(glm::vec3(std::cos(2 * kPi * (s + 0.5f) / segments), 0, std::sin(2 * kPi * (s + 0.5f) / segments)) *
                             std::sin(kPi * (r + 0.5f) / rings) +
                         glm::vec3(0, std::cos(kPi * (r + 0.5f) / rings), 0));
      if (r != 0) b.triangle(id[r][s], id[r + 1][s], id[r][s + 1], out);
      if (r + 1 != rings) b.triangle(id[r][s + 1], id[r + 1][s], id[r + 1][s + 1], out);
    }
  }
  return b.finish("sphere", 0);
}

// A flat n x n grid of quads in the plane y = `y`, facing up.
scenes::Mesh grid(float half, float y, uint32_t n) {
  scenes::MeshBuilder b;
  std::vector<uint32_t> id;
  for (uint32_t j = 0; j <= n; ++j) {
    for (uint32_t i = 0; i <= n; ++i) {
      glm::vec3 p(-half + 2 * half * i / n, y, -half + 2 * half * j / n);
      id.push_back(b.vertex(p, glm::vec3(0, 1, 0), glm::vec2(p.x, p.z) * 0.5f));
    }
  }
  for (uint32_t j = 0; j < n; ++j) {
    for (uint32_t i = 0; i < n; ++i) {
      uint32_t a = id[j * (n + 1) + i], c = id[j * (n + 1) + i + 1], d = id[(j + 1) * (n + 1) + i],
               e = id[(j + 1) * (n + 1) + i + 1];
      b.triangle(a, c, e, glm::vec3(0, 1, 0));
      b.triangle(a, e, d, glm::vec3(0, 1, 0));
    }
  }
  return b.finish("grid", 0);
}

SimplifiedLevels levelsOf(const scenes::Mesh& m) {
  return simplifyLevels(m.indices, &m.vertices[0].position.x, m.vertices.size(), sizeof(scenes::Vertex));
}

void expectChain(const scenes::Mesh& m, const SimplifiedLevels& l, const std::string& what) {
  ASSERT_GE(l.indices.size(), 2u) << what << ": at least two coarser levels";
  EXPECT_LE(l.indices.size() + 1, kLodMaxLevels) << what;
  size_t previous = m.indices.size();
  float previousError = 0;
  for (size_t i = 0; i < l.indices.size(); ++i) {
    EXPECT_LT(l.indices[i].size(), previous) << what << " level " << i + 1;
    EXPECT_EQ(l.indices[i].size() % 3, 0u) << what;
    EXPECT_GE(l.indices[i].size(), kLodMinIndices) << what;
    EXPECT_GE(l.errors[i], previousError) << what << " level " << i + 1 << ": errors monotone";
    for (uint32_t v : l.indices[i]) EXPECT_LT(v, m.vertices.size()) << what;
    previous = l.indices[i].size();
    previousError = l.errors[i];
  }
}

TEST(Lod, ChainsShrinkAndErrorsAreMonotoneAndBounded) {
  // A flat grid simplifies without leaving its plane: every level's error is
  // 0 (to float precision of its 8 m extent); its border is locked, so its
  // 4 x 32 boundary edges stay.
  const scenes::Mesh g = grid(4.0f, 0.0f, 32);
  const SimplifiedLevels gl = levelsOf(g);
  expectChain(g, gl, "grid");
  for (float e : gl.errors) EXPECT_LE(e, 1e-4f * 8.0f) << "grid: planar simplification has no error";
  // Border locked: every boundary vertex of the grid is still referenced by
  // the coarsest level (cracks cannot open against a neighbouring mesh).
  std::set<uint32_t> kept(gl.indices.back().begin(), gl.indices.back().end());
  for (uint32_t i = 0; i <= 32; ++i) {
    EXPECT_TRUE(kept.count(i)) << "grid border vertex " << i << " dropped";
    EXPECT_TRUE(kept.count(32 * 33 + i)) << "grid border vertex " << 32 * 33 + i << " dropped";
  }
  // A sphere of radius r: every vertex, original or kept, lies on it, so no
  // level's distance to the original surface exceeds the diameter 2r; and a
  // coarse level (a few dozen triangles) cannot be exact.
  const float r = 1.5f;
  const scenes::Mesh s = sphere(glm::vec3(0), r, 48, 24);
  const SimplifiedLevels sl = levelsOf(s);
  expectChain(s, sl, "sphere");
  for (float e : sl.errors) EXPECT_LE(e, 2 * r) << "sphere";
  EXPECT_GT(sl.errors.back(), 0.0f) << "sphere: the coarsest level has an error";
  // The sagitta of the coarsest level's mean edge bounds its error from
  // below loosely: with T triangles on a sphere the mean triangle spans
  // 4 pi r^2 / T, and a chord of edge a deviates a^2 / (8 r) from the sphere.
  const double t = double(sl.indices.back().size() / 3);
  const double edge = std::sqrt(4 * kPi * r * r / t * 4 / std::sqrt(3.0));
  EXPECT_GE(sl.errors.back(), 0.1 * edge * edge / (8 * r)) << "sphere: coarsest error vs sagitta " << t;
}

TEST(Lod, ProjectedErrorFormula) {
  // 90 px high, 60 degrees: 90 / (2 tan 30) = 77.94 px per unit at distance 1.
  EXPECT_NEAR(pixelsPerUnitAtUnitDistance(90, kPi / 3), 90 / (2 * std::tan(kPi / 6)), 1e-3);
  EXPECT_NEAR(projectedErrorPx(0.1f, 10.0f, 90, kPi / 3), 0.01 * 77.9423, 1e-3);
  LodChain c;
  c.center = glm::vec3(0, 0, -10);
  c.radius = 1;
  c.levels = {{0, 300, 0.0f}, {300, 150, 0.01f}, {450, 75, 0.05f}, {525, 48, 0.2f}};
  // From the origin the sphere is 9 away: errors project to 0.087, 0.433, 1.732 px.
  EXPECT_EQ(selectLevel(c, glm::vec3(0), 90, kPi / 3, 0.05f), 0u);
  EXPECT_EQ(selectLevel(c, glm::vec3(0), 90, kPi / 3, 0.1f), 1u);
  EXPECT_EQ(selectLevel(c, glm::vec3(0), 90, kPi / 3, 1.0f), 2u);
  EXPECT_EQ(selectLevel(c, glm::vec3(0), 90, kPi / 3, 2.0f), 3u);
  // Inside the bounding sphere: the finest level for any finite threshold.
  EXPECT_EQ(selectLevel(c, glm::vec3(0, 0, -10.5f), 90, kPi / 3, 8.0f), 0u);
}

TEST(Lod, OptionTable) {
  for (const std::string& r : rendererNames()) {
    auto off = canonicalOptions(r, {{"lod", "off"}});
    ASSERT_TRUE(off.ok()) << r;
    EXPECT_EQ(*off, nlohmann::json::object()) << r << ": off is the default";
    for (const nlohmann::json& v : {nlohmann::json(0.5), nlohmann::json(1), nlohmann::json(8)}) {
      auto ok = canonicalOptions(r, {{"lod", v}});
      ASSERT_TRUE(ok.ok()) << r << " " << v;
      RendererOptions o;
      applyOptions(*ok, o);
      EXPECT_EQ(o.lodThresholdPx, v.get<float>());
    }
  }
  for (const nlohmann::json& bad : {nlohmann::json(3), nlohmann::json(0), nlohmann::json(-1), nlohmann::json("on"),
                                   nlohmann::json(true), nlohmann::json(1.5)}) {
    auto r = canonicalOptions("forward", {{"lod", bad}});
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.error().find("lod"), std::string::npos) << r.error();
  }
  EXPECT_EQ(variantLabel("visbuffer", *canonicalOptions("visbuffer", {{"lod", 2}})), "visbuffer lod=2");
  auto it = std::find_if(optionDefs().begin(), optionDefs().end(), [](const OptionDef& d) { return d.name == "lod"; });
  ASSERT_NE(it, optionDefs().end());
  EXPECT_EQ(it->defaultValue(), "off");
  EXPECT_FALSE(it->parameter);
}

// Three spheres at 0, 12 and 40 m behind the near one and a floor grid.
struct LodScene {
  scenes::Scene scene;
  GpuScene gpu;
  scenes::Camera camera;
};

LodScene& lodScene() {
  // Never freed: the fixture's environment destroys the device before
  // statics die, and GpuScene::destroy needs it (the process ends anyway).
  static LodScene* s = nullptr;
  if (s == nullptr) {
    s = new LodScene();
    s->scene.name = "lod-test";
    s->scene.meshes = {sphere({0, 0, 0}, 1.0f, 48, 24), sphere({1.5f, 0, -12}, 1.0f, 48, 24),
                       sphere({-3, 0, -40}, 1.0f, 48, 24), grid(50.0f, -1.0f, 24)};
    for (const auto& m : s->scene.meshes) s->scene.bounds.extend(m.bounds);
    s->camera.eye = glm::vec3(0, 0.5f, 3.5f);
    s->camera.target = glm::vec3(0, 0, -10);
    s->camera.fovDeg = 60;
    if (context() != nullptr) {
      auto ok = s->gpu.upload(*context(), s->scene);
      EXPECT_TRUE(ok.ok()) << (ok ? "" : ok.error());
    }
  }
  return *s;
}

struct LodRender {
  FrameResult frame;
  std::vector<uint8_t> image;
  nlohmann::json extras;
  std::vector<ResourceInfo> resources;
};

constexpr VkExtent2D kExtent = {160, 90};

LodRender renderLod(const std::string& name, float threshold) {
  LodRender out;
  LodScene& s = lodScene();
  auto renderer = makeRenderer(name);
  EXPECT_TRUE(renderer.ok());
  RendererOptions o;
  o.extent = kExtent;
  o.lights = kTestLights;
  o.lodThresholdPx = threshold;
  auto ok = (*renderer)->setup(*context(), s.gpu, o);
  EXPECT_TRUE(ok.ok()) << (ok ? "" : ok.error());
  if (!ok) return out;
  out.frame = (*renderer)->renderFrame(s.camera);
  out.image = (*renderer)->finalImage();
  out.extras = (*renderer)->frameExtras();
  out.resources = (*renderer)->resources();
  (*renderer)->destroy();
  return out;
}

// The level each draw should take, from the stored chain and the camera
// alone: the largest l with e_l / (|eye - c| - r) x H / (2 tan(fov / 2)) <= t.
std::vector<uint32_t> predictedLevels(const SceneLod& lod, const scenes::Camera& camera, float t) {
  std::vector<uint32_t> out;
  const double k = kExtent.height / (2 * std::tan(camera.fovDeg * kPi / 180 / 2));
  for (const auto& c : lod.chains()) {
    const double d = std::max(double(glm::distance(camera.eye, c.center)) - c.radius * c.modelScale, 1e-4);
    uint32_t level = 0;
    for (uint32_t l = 0; l < c.levels.size(); ++l) {
      if (double(c.levels[l].error) * c.modelScale / d * k <= t) level = l;
    }
    out.push_back(level);
  }
  return out;
}

uint64_t accessCount(const PassResult& p, const std::string& resource, const std::string& source) {
  uint64_t n = 0;
  for (const auto& a : p.accesses) {
    if (!a.write && a.resource == resource && a.source == source) n += a.count;
  }
  return n;
}

TEST(Lod, ChosenLevelsCountsAndImage) {
  if (context() == nullptr) TALLY_SKIP_UNLESS_STRICT("no Vulkan device");
  LodScene& s = lodScene();
  auto built = s.gpu.lod();
  ASSERT_TRUE(built.ok()) << (built ? "" : built.error());
  const SceneLod& lod = **built;
  ASSERT_EQ(lod.chains().size(), 4u);
  // The grid's chain: every level exact (planar), so every threshold takes
  // its coarsest level, whatever the distance.
  const LodChain& floor = lod.chains()[3];
  ASSERT_GE(floor.levels.size(), 3u);

  const LodRender off = renderLod("forward", 0);
  EXPECT_FALSE(off.extras.contains("lod")) << "lod off adds nothing";
  uint64_t previousTriangles = UINT64_MAX;
  for (float t : {0.5f, 1.0f, 2.0f, 4.0f, 8.0f}) {
    const std::string where = "lod=" + std::to_string(t);
    const std::vector<uint32_t> want = predictedLevels(lod, s.camera, t);
    EXPECT_EQ(want[3], floor.levels.size() - 1) << where << ": the flat floor takes its coarsest level";
    const LodRender r = renderLod("forward", t);
    ASSERT_TRUE(r.extras.contains("lod")) << where;
    const auto& e = r.extras["lod"];
    uint64_t indices = 0, triangles = 0, full = 0;
    std::vector<uint64_t> histogram;
    std::set<std::pair<int32_t, uint32_t>> unique;  // (draw, vertex) the chosen levels reference
    const auto idx = gpu::readBuffer(*context(), lod.indices());
    const auto* all = reinterpret_cast<const uint32_t*>(idx.data());
    for (uint32_t d = 0; d < want.size(); ++d) {
      const LodLevel& l = lod.chains()[d].levels[want[d]];
      indices += l.indexCount;
      full += lod.chains()[d].levels[0].indexCount / 3;
      if (histogram.size() <= want[d]) histogram.resize(want[d] + 1);
      ++histogram[want[d]];
      for (uint32_t i = 0; i < l.indexCount; ++i) unique.insert({int32_t(d), all[l.firstIndex + i]});
    }
    triangles = indices / 3;
    EXPECT_EQ(e["levels"].get<std::vector<uint64_t>>(), histogram) << where;
    EXPECT_EQ(e["triangles_drawn"].get<uint64_t>(), triangles) << where;
    EXPECT_EQ(e["triangles_full"].get<uint64_t>(), full) << where;
    EXPECT_LE(e["max_projected_error_px"].get<double>(), t + 1e-4) << where;
    EXPECT_LE(triangles, previousTriangles) << where << ": a larger threshold never draws more";
    previousTriangles = triangles;
    // Index fetches of the geometry pass: the chosen levels' index counts.
    const PassResult& geometry = r.frame.passes.at(0);
    ASSERT_EQ(geometry.name, "forward");
    EXPECT_EQ(accessCount(geometry, "indices", "derived"), indices) << where;
    // Vertex invocations (draws[].model is read once per vertex): between
    // the distinct vertices the chosen levels reference and their indices.
    const uint64_t vertices = accessCount(geometry, "draws", "counter");
    EXPECT_GE(vertices, unique.size()) << where;
    EXPECT_LE(vertices, indices) << where;
    // "indices" grew by the coarser levels: the real allocation holds them.
    for (const auto& info : r.resources) {
      if (info.name == "indices") {
        EXPECT_GE(info.allocationBytes, lod.indexCount() * 4) << where;
      }
    }
    EXPECT_EQ(e["index_buffer_bytes_added"].get<uint64_t>(),
              (lod.indexCount() - (lod.chains()[3].levels[0].firstIndex + lod.chains()[3].levels[0].indexCount)) * 4);
    // Image: with a 1 px threshold, silhouettes move by at most about a pixel
    // and interiors keep the original vertices' normals: mean error below 1
    // level of 255 and PSNR above 30 dB against LOD off.
    if (t == 1.0f) {
      auto err = analysis::compareImages(r.image, off.image, kExtent.width, kExtent.height);
      ASSERT_TRUE(err.ok());
      std::printf("lod=1 vs off: psnr %.2f dB, mean %.3f, max %d; triangles %llu of %llu\n", err->psnr, err->meanAbs,
                  err->maxAbs, (unsigned long long)triangles, (unsigned long long)full);
      EXPECT_LT(err->meanAbs, 1.0);
      EXPECT_GT(err->psnr, 30.0);
      EXPECT_LT(triangles, full) << "lod=1 must simplify something in this scene";
    }
  }
}

TEST(Lod, VisibilityBufferShadesTheChosenLevelsTriangles) {
  if (context() == nullptr) TALLY_SKIP_UNLESS_STRICT("no Vulkan device");
  // The shading pass fetches its triangle through draws[id].firstIndex: with
  // the per-frame draws buffer it is the level the visibility pass drew. A
  // mismatch would shade other triangles' attributes; so visbuffer with
  // lod=8 must match forward with lod=8 as closely as without LOD.
  LodScene& s = lodScene();
  auto built = s.gpu.lod();
  ASSERT_TRUE(built.ok());
  const std::vector<uint32_t> want = predictedLevels(**built, s.camera, 8.0f);
  for (const char* name : {"visbuffer", "visbuffer-lean"}) {
    const LodRender fOff = renderLod("forward", 0), vOff = renderLod(name, 0);
    const LodRender fOn = renderLod("forward", 8), vOn = renderLod(name, 8);
    const double base = analysis::psnr(vOff.image, fOff.image), lod = analysis::psnr(vOn.image, fOn.image);
    std::printf("%s vs forward: psnr %.2f dB off, %.2f dB lod=8\n", name, base, lod);
    EXPECT_GT(lod, std::min(base, 60.0) - 3.0) << name;
    uint64_t indices = 0;
    for (uint32_t d = 0; d < want.size(); ++d) indices += (**built).chains()[d].levels[want[d]].indexCount;
    EXPECT_EQ(accessCount(vOn.frame.passes.at(0), "indices", "derived"), indices) << name;
    EXPECT_EQ(vOn.extras["lod"]["triangles_drawn"].get<uint64_t>(), indices / 3) << name;
  }
}

}  // namespace
}  // namespace tally::renderers
