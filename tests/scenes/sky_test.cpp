// sky: one quad over the bottom `coverage` of the screen, the rest sky.
#include <gtest/gtest.h>

#include "scene_test_util.hpp"
#include "scenes/cameras.hpp"
#include "scenes/procedural.hpp"

namespace tally::scenes {
namespace {

TEST(Sky, MeasuredSkyFractionIsOneMinusCoverage) {
  for (float coverage : {0.0f, 0.1f, 0.25f, 0.5f, 0.8f, 1.0f}) {
    Scene s = makeSky({coverage});
    EXPECT_EQ(s.triangleCount(), 2u);
    ASSERT_EQ(s.fixedCameras.size(), 1u);
    for (float aspect : {16.0f / 9.0f, 1280.0f / 1024.0f}) {
      float sky = skyFraction(s, s.fixedCameras[0], aspect, kSkyRaysX, kSkyRaysY);
      EXPECT_NEAR(sky, 1.0f - coverage, 1.0f / kSkyRaysY + 1e-6f) << "coverage " << coverage;
    }
  }
}

TEST(Sky, GeometryFillsTheBottomRows) {
  Scene s = makeSky({0.5f});
  // Top half of the grid: all sky; bottom half: all geometry.
  EXPECT_FLOAT_EQ(skyFraction(s, s.fixedCameras[0], 16.0f / 9.0f, 32, 18), 0.5f);
  EXPECT_EQ(s.params, (nlohmann::json{{"name", "sky"}, {"coverage", 0.5}}));
}

TEST(Sky, AutoCamerasStartWithTheFixedCamera) {
  Scene s = makeSky({0.5f});
  std::vector<Camera> cams = autoCameras(s);
  ASSERT_EQ(cams.size(), size_t(kAutoCameraCount));
  EXPECT_EQ(cams[0].eye, s.fixedCameras[0].eye);
  EXPECT_EQ(cams[0].target, s.fixedCameras[0].target);
  bool mostly = false, half = false;
  for (const Camera& c : cams) {
    EXPECT_EQ(c.eye, s.fixedCameras[0].eye) << "rotations about the fixed eye only";
    mostly = mostly || c.skyFraction > kMostlySky;
    half = half || (c.skyFraction >= kHalfSkyLo && c.skyFraction <= kHalfSkyHi);
  }
  // The quad spans less than the field of view vertically, so no view is all
  // geometry; the other two categories exist.
  EXPECT_TRUE(mostly);
  EXPECT_TRUE(half);
}

}  // namespace
}  // namespace tally::scenes
