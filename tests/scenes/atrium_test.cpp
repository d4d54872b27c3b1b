// atrium: the default scene.
#include <chrono>
#include <set>

#include <gtest/gtest.h>

#include "scene_test_util.hpp"
#include "scenes/cameras.hpp"
#include "scenes/procedural.hpp"

namespace tally::scenes {
namespace {

TEST(Atrium, IsDeterministic) {
  Scene a = makeAtrium(), b = makeAtrium();
  EXPECT_EQ(contentHash(a), contentHash(b));
  EXPECT_EQ(a.triangleCount(), b.triangleCount());
}

TEST(Atrium, StaysSmall) {
  Scene s = makeAtrium();
  std::printf("atrium: %zu triangles, %zu vertices, %zu meshes\n", s.triangleCount(), s.vertexCount(),
              s.meshes.size());
  for (const Mesh& m : s.meshes) std::printf("  %-10s %5zu triangles\n", m.name.c_str(), m.triangleCount());
  EXPECT_LT(s.triangleCount(), 10000u);
  EXPECT_GT(s.triangleCount(), 1000u);
  for (const Mesh& m : s.meshes) {
    EXPECT_FALSE(m.indices.empty()) << m.name;
    for (uint32_t i : m.indices) ASSERT_LT(i, m.vertices.size()) << m.name;
  }
}

TEST(Atrium, FiveMaterialsOrMoreEachWithFiveGeneratedMaps) {
  Scene s = makeAtrium();
  EXPECT_GE(s.materials.size(), 5u);
  std::set<int32_t> used;
  for (const Material& m : s.materials) {
    for (size_t slot = 0; slot < kMapSlotCount; ++slot) {
      int32_t t = m.maps[slot];
      ASSERT_GE(t, 0) << m.name << " " << toString(MapSlot(slot));
      ASSERT_LT(size_t(t), s.textures.size());
      EXPECT_TRUE(used.insert(t).second) << "maps are not shared between slots or materials";
      const Texture& tex = s.textures[size_t(t)];
      EXPECT_GE(tex.width, 128u);
      EXPECT_EQ(tex.rgba8.size(), size_t(tex.width) * tex.height * 4);
      EXPECT_EQ(tex.srgb, MapSlot(slot) == MapSlot::Diffuse) << tex.name;
      // Generated, not flat: the texels vary.
      std::set<uint32_t> values;
      for (size_t i = 0; i < tex.rgba8.size(); i += 4)
        values.insert(tex.rgba8[i] | tex.rgba8[i + 1] << 8 | tex.rgba8[i + 2] << 16);
      EXPECT_GT(values.size(), 1u) << tex.name;
    }
  }
  // Every material is drawn.
  std::set<uint32_t> drawn;
  for (const Mesh& m : s.meshes) drawn.insert(m.material);
  EXPECT_EQ(drawn.size(), s.materials.size());
}

TEST(Atrium, TangentFramesAreOrthonormal) { test::expectOrthonormalTangents(makeAtrium(), 1e-4f); }

TEST(Atrium, AutoCamerasCoverTheSkyCategories) {
  Scene s = makeAtrium();
  auto t0 = std::chrono::steady_clock::now();
  std::vector<Camera> cams = autoCameras(s);
  double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("atrium auto cameras (%.0f ms):\n", ms);
  test::printCameras(cams);
  test::expectSkyCategories(cams);
  for (const Camera& c : cams) {
    EXPECT_TRUE(s.bounds.min.x <= c.eye.x && c.eye.x <= s.bounds.max.x) << c.label;
    EXPECT_TRUE(s.bounds.min.y <= c.eye.y && c.eye.y <= s.bounds.max.y) << c.label;
  }
  // Deterministic.
  std::vector<Camera> again = autoCameras(s);
  ASSERT_EQ(again.size(), cams.size());
  for (size_t i = 0; i < cams.size(); ++i) {
    EXPECT_EQ(again[i].eye, cams[i].eye);
    EXPECT_EQ(again[i].target, cams[i].target);
    EXPECT_EQ(again[i].skyFraction, cams[i].skyFraction);
  }
}

}  // namespace
}  // namespace tally::scenes
