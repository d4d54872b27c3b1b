// Camera lists from JSON, the view convention, the BVH and the sky estimate.
#include <cmath>

#include <gtest/gtest.h>

#include "scene_test_util.hpp"
#include "scenes/bvh.hpp"
#include "scenes/cameras.hpp"
#include "scenes/mesh_builder.hpp"
#include "scenes/procedural.hpp"

namespace tally::scenes {
namespace {

using nlohmann::json;

TEST(CamerasFromJson, ReadsAList) {
  json list = json::parse(R"([
    {"eye": [0, 1, 2], "target": [0, 1, -5]},
    {"eye": [1, 2, 3], "target": [4, 5, 6], "fov_deg": 45, "label": "close", "sky_fraction": 0.25}
  ])");
  Result<std::vector<Camera>> r = camerasFromJson(list);
  ASSERT_TRUE(r.ok()) << r.error();
  ASSERT_EQ(r->size(), 2u);
  EXPECT_EQ((*r)[0].eye, glm::vec3(0, 1, 2));
  EXPECT_EQ((*r)[0].fovDeg, 60.0f);
  EXPECT_EQ((*r)[0].skyFraction, -1.0f);
  EXPECT_EQ((*r)[1].fovDeg, 45.0f);
  EXPECT_EQ((*r)[1].label, "close");
  // Round trip through toJson.
  json back = json::array({toJson((*r)[0]), toJson((*r)[1])});
  Result<std::vector<Camera>> again = camerasFromJson(back);
  ASSERT_TRUE(again.ok()) << again.error();
  EXPECT_EQ((*again)[1].target, (*r)[1].target);
  EXPECT_EQ((*again)[1].skyFraction, 0.25f);
}

TEST(CamerasFromJson, ErrorsNameTheElementAndField) {
  const std::pair<const char*, const char*> cases[] = {
      {R"({"eye": [0,0,0]})", "must be an array of cameras"},
      {R"([])", "must hold at least one camera"},
      {R"([5])", "[0]: must be an object"},
      {R"([{"target": [0,0,1]}])", "[0].eye: missing"},
      {R"([{"eye": [0,0,0], "target": [0,0,1]}, {"eye": [1,2], "target": [0,0,1]}])",
       "[1].eye: must be an array of 3 finite numbers, got [1,2]"},
      {R"([{"eye": [0,0,0], "target": ["a",0,1]}])", "[0].target: must be an array of 3"},
      {R"([{"eye": [0,0,0], "target": [0,0,0]}])", "[0].target: must differ from eye"},
      {R"([{"eye": [0,0,0], "target": [0,0,1], "fov_deg": 0}])",
       "[0].fov_deg: must be a number of degrees in (0, 180), got 0"},
      {R"([{"eye": [0,0,0], "target": [0,0,1], "fov_deg": 200}])", "[0].fov_deg:"},
      {R"([{"eye": [0,0,0], "target": [0,0,1], "fov": 60}])", "[0].fov: unknown key"},
      {R"([{"eye": [0,0,0], "target": [0,0,1], "sky_fraction": 2}])",
       "[0].sky_fraction: must be a number in [0, 1]"},
      {R"([{"eye": [0,0,0], "target": [0,0,1], "label": 7}])", "[0].label: must be a string"},
  };
  for (const auto& [text, prefix] : cases) {
    Result<std::vector<Camera>> r = camerasFromJson(json::parse(text));
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_EQ(r.error().rfind(prefix, 0), 0u) << text << " -> " << r.error();
  }
}

TEST(ViewMatrix, StaysDefinedLookingStraightUpOrDown) {
  for (float dy : {1.0f, -1.0f}) {
    Camera c;
    c.eye = glm::vec3(1, 2, 3);
    c.target = c.eye + glm::vec3(0, dy, 0);
    glm::mat4 v = viewMatrix(c);
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) EXPECT_TRUE(std::isfinite(v[i][j]));
    // The eye maps to the origin and the target onto -Z.
    glm::vec4 t = v * glm::vec4(c.target, 1.0f);
    EXPECT_NEAR(t.x, 0.0f, 1e-5f);
    EXPECT_NEAR(t.y, 0.0f, 1e-5f);
    EXPECT_NEAR(t.z, -1.0f, 1e-5f);
  }
}

TEST(Bvh, ClosestHitDistanceAndSide) {
  Scene s = makeSky({1.0f});  // one quad at z = -4 facing +Z
  Bvh bvh = Bvh::build(s);
  EXPECT_EQ(bvh.triangleCount(), 2u);
  std::optional<Hit> front = bvh.closestHit({glm::vec3(0, 0, 0), glm::vec3(0, 0, -1)});
  ASSERT_TRUE(front.has_value());
  EXPECT_NEAR(front->t, 4.0f, 1e-5f);
  EXPECT_FALSE(front->backFace);
  std::optional<Hit> back = bvh.closestHit({glm::vec3(0, 0, -10), glm::vec3(0, 0, 1)});
  ASSERT_TRUE(back.has_value());
  EXPECT_NEAR(back->t, 6.0f, 1e-5f);
  EXPECT_TRUE(back->backFace);
  EXPECT_FALSE(bvh.anyHit({glm::vec3(0, 0, 0), glm::vec3(0, 0, 1)}));
  EXPECT_FALSE(bvh.anyHit({glm::vec3(0, 0, 0), glm::vec3(0, 0, -1), 3.9f})) << "tMax bounds the ray";
}

// Many layers: the closest of 1024 stacked quads is found, from either end.
TEST(Bvh, ClosestOfManyLayers) {
  Scene s = makePlanes({kMaxPlaneLayers, DrawOrder::BackToFront, 1.0f});
  Bvh bvh = Bvh::build(s);
  std::optional<Hit> h = bvh.closestHit({glm::vec3(0.1f, 0.2f, 0.0f), glm::vec3(0, 0, -1)});
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(h->t, 2.0f, 1e-4f);
  std::optional<Hit> far = bvh.closestHit({glm::vec3(0.1f, 0.2f, -1000.0f), glm::vec3(0, 0, 1)});
  ASSERT_TRUE(far.has_value());
  EXPECT_NEAR(far->t, 1000.0f - (2.0f + 0.1f * (kMaxPlaneLayers - 1)), 1e-2f);
}

TEST(SkyFraction, EmptySceneIsAllSky) {
  Scene empty;
  Camera c;
  EXPECT_EQ(skyFraction(empty, c), 1.0f);
  EXPECT_TRUE(autoCameras(empty).empty());
}

}  // namespace
}  // namespace tally::scenes

namespace tally::scenes {
namespace {

// A solid block: no eye inside its bounds is in open space, so the cameras
// look at it from outside.
TEST(AutoCameras, FallBackToOutsideViewsOfASolid) {
  Scene s;
  MeshBuilder b;
  b.box(glm::vec3(-1.0f), glm::vec3(1.0f), 1.0f);
  s.meshes.push_back(b.finish("block", 0));
  s.materials.push_back({});
  updateBounds(s);
  std::vector<Camera> cams = autoCameras(s);
  ASSERT_EQ(cams.size(), size_t(kAutoCameraCount));
  for (const Camera& c : cams) {
    EXPECT_GT(glm::length(c.eye), std::sqrt(3.0f)) << c.label;
    EXPECT_LT(c.skyFraction, 1.0f) << c.label << ": the block is in view";
  }
}

}  // namespace
}  // namespace tally::scenes
