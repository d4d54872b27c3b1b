// planes: N stacked quads whose coverage and draw order are exactly known.
#include <cmath>

#include <gtest/gtest.h>

#include "scene_test_util.hpp"
#include "scenes/cameras.hpp"
#include "scenes/procedural.hpp"

namespace tally::scenes {
namespace {

TEST(Planes, TwoTrianglesPerLayerOneMeshEach) {
  for (int layers : {1, 8, 100, kMaxPlaneLayers}) {
    Scene s = makePlanes({layers, DrawOrder::BackToFront, 1.0f});
    EXPECT_EQ(s.triangleCount(), size_t(2 * layers));
    EXPECT_EQ(s.meshes.size(), size_t(layers));
    EXPECT_EQ(s.materials.size(), 1u);
    for (const Mesh& m : s.meshes) EXPECT_EQ(m.material, 0u);
  }
}

TEST(Planes, OneMaterialWithAllFiveMaps) {
  Scene s = makePlanes({});
  ASSERT_EQ(s.materials.size(), 1u);
  for (int32_t t : s.materials[0].maps) {
    ASSERT_GE(t, 0);
    ASSERT_LT(size_t(t), s.textures.size());
  }
  EXPECT_EQ(s.params, (nlohmann::json{
                          {"name", "planes"}, {"layers", 8}, {"order", "back-to-front"}, {"coverage", 1.0}}));
}

TEST(Planes, FixedCameraLooksHeadOnDownMinusZ) {
  Scene s = makePlanes({});
  ASSERT_EQ(s.fixedCameras.size(), 1u);
  const Camera& c = s.fixedCameras[0];
  glm::vec3 d = glm::normalize(c.target - c.eye);
  EXPECT_NEAR(d.z, -1.0f, 1e-6f);
  for (const Mesh& m : s.meshes)
    for (const Vertex& v : m.vertices) EXPECT_NEAR(v.normal.z, 1.0f, 1e-6f);
}

// Every layer projects to exactly NDC y = +-coverage, whatever its depth.
TEST(Planes, QuadsProjectToExactlyTheCoverage) {
  for (float coverage : {1.0f, 0.5f, 0.3f}) {
    Scene s = makePlanes({16, DrawOrder::BackToFront, coverage});
    const Camera& c = s.fixedCameras[0];
    const float tanHalf = std::tan(glm::radians(c.fovDeg) * 0.5f);
    for (const Mesh& m : s.meshes)
      for (const Vertex& v : m.vertices) {
        float depth = c.eye.z - v.position.z;
        EXPECT_NEAR(std::abs(v.position.y) / (depth * tanHalf), coverage, 1e-5f);
        EXPECT_NEAR(std::abs(v.position.x) / (depth * tanHalf), kMaxAnalyticAspect, 1e-5f);
      }
  }
}

// The CPU ray cast agrees with the analytic coverage within one row of the
// ray grid, at 16:9 and at 5:4 (1280x1024).
TEST(Planes, RayCastCoverageMatches) {
  for (float coverage : {1.0f, 0.75f, 0.5f, 0.25f, 0.1f}) {
    Scene s = makePlanes({4, DrawOrder::FrontToBack, coverage});
    for (float aspect : {16.0f / 9.0f, 1280.0f / 1024.0f}) {
      float sky = skyFraction(s, s.fixedCameras[0], aspect, kSkyRaysX, kSkyRaysY);
      EXPECT_NEAR(1.0f - sky, coverage, 1.0f / kSkyRaysY + 1e-6f)
          << "coverage " << coverage << " aspect " << aspect;
    }
    EXPECT_FLOAT_EQ(s.fixedCameras[0].skyFraction, 1.0f - coverage);
  }
}

// Rotations about the fixed eye keep every layer on the same pixels, and
// reach all three sky categories.
TEST(Planes, AutoCamerasKeepTheEyeAndCoverTheCategories) {
  Scene s = makePlanes({});
  std::vector<Camera> cams = autoCameras(s);
  ASSERT_EQ(cams.size(), size_t(kAutoCameraCount));
  EXPECT_EQ(cams[0].target, s.fixedCameras[0].target);
  for (const Camera& c : cams) EXPECT_EQ(c.eye, s.fixedCameras[0].eye);
  test::expectSkyCategories(cams);
}

TEST(Planes, OrderReversesTheDrawOrder) {
  const int layers = 6;
  Scene b2f = makePlanes({layers, DrawOrder::BackToFront, 1.0f});
  Scene f2b = makePlanes({layers, DrawOrder::FrontToBack, 1.0f});
  auto depth = [](const Mesh& m) { return -m.bounds.max.z; };  // the camera looks down -Z from z = 0
  for (int i = 1; i < layers; ++i) {
    EXPECT_GT(depth(b2f.meshes[i - 1]), depth(b2f.meshes[i])) << "back-to-front: farthest first";
    EXPECT_LT(depth(f2b.meshes[i - 1]), depth(f2b.meshes[i])) << "front-to-back: nearest first";
  }
  for (int i = 0; i < layers; ++i)
    EXPECT_EQ(b2f.meshes[i].vertices[0].position, f2b.meshes[layers - 1 - i].vertices[0].position);
}

}  // namespace
}  // namespace tally::scenes
