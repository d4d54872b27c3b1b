// The visibility id's capacity (shared.h, visbuffer_base.hpp): at the limit
// the visibility buffers render exactly what the prediction says; one draw
// over it they refuse with the limit and the scene's count, while the other
// renderers, which have no such limit, still render. The per-draw triangle
// limit (8,388,607) is checked on scene descriptions: a mesh that size is
// too large to build in CI.
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analytic.hpp"
#include "analysis/image.hpp"
#include "render_fixture.hpp"
#include "renderers/visbuffer_base.hpp"
#include "shared.h"

namespace tally::renderers {
using namespace fixture;
namespace {

constexpr VkExtent2D kExtent = {37, 21};  // small and odd: 512 layers stay quick on lavapipe
constexpr double kMinPsnrDb = 30.0;      // as renderers_test.cpp: agreement with forward
const char* const kVisbuffers[] = {"visbuffer", "visbuffer-lean"};

std::vector<GpuDraw> draws(size_t count, uint32_t trianglesEach) {
  GpuDraw d;
  d.indexCount = trianglesEach * 3;
  return std::vector<GpuDraw>(count, d);
}

bool mentions(const std::string& text, uint64_t number) {
  return text.find(std::to_string(number)) != std::string::npos;
}

TEST(VisibilityIdCapacity, DrawLimitIsTheDrawIdBits) {
  EXPECT_EQ(shaders::kMaxDraws, 1u << shaders::kDrawIdBits);
  EXPECT_EQ(visibilityIdOverflow(draws(shaders::kMaxDraws, 2)), "");
  const std::string why = visibilityIdOverflow(draws(shaders::kMaxDraws + 1, 2));
  EXPECT_TRUE(mentions(why, shaders::kMaxDraws + 1)) << why;
  EXPECT_TRUE(mentions(why, shaders::kMaxDraws)) << why;
}

TEST(VisibilityIdCapacity, TriangleLimitKeepsTheClearValueFree) {
  // The last triangle id of the last draw must not pack to the clear value.
  const uint32_t lastId = shaders::packVisibilityId(shaders::kMaxDraws - 1, shaders::kTriangleIdMask - 1);
  EXPECT_NE(lastId, shaders::kVisibilityClear);
  EXPECT_EQ(shaders::visibilityTriangleId(lastId), shaders::kTriangleIdMask - 1);
  EXPECT_EQ(shaders::visibilityDrawId(lastId), shaders::kMaxDraws - 1);

  auto scene = draws(3, 2);
  scene[1].indexCount = shaders::kTriangleIdMask * 3;  // triangle ids 0 .. mask - 1
  EXPECT_EQ(visibilityIdOverflow(scene), "");
  scene[1].indexCount = (shaders::kTriangleIdMask + 1) * 3;
  const std::string why = visibilityIdOverflow(scene);
  EXPECT_TRUE(mentions(why, shaders::kTriangleIdMask + 1)) << why;
  EXPECT_TRUE(mentions(why, shaders::kTriangleIdMask)) << why;
  EXPECT_NE(why.find("draw 1"), std::string::npos) << why;
}

// planes with one draw per layer: kMaxDraws layers back to front, so the
// visible layer is the last draw (the largest draw id) everywhere.
TEST(VisibilityIdCapacity, AtTheDrawLimitTheVisibilityBuffersRenderExactly) {
  const auto spec = planes(int(shaders::kMaxDraws), "back-to-front", 0.5);
  const analytic::Geometry g = analytic::geometryOf(spec, kExtent);
  ASSERT_FALSE(g.rows.ambiguous);
  Rendered reference = render("forward", spec, kExtent);
  ASSERT_TRUE(reference.ok) << reference.error;
  for (const char* name : kVisbuffers) {
    Rendered r = render(name, spec, kExtent);
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    EXPECT_GE(analysis::psnr(reference.image, r.image), kMinPsnrDb) << name;
    analytic::DeviceTraits device;
    device.lights = kTestLights;
    device.barycentricExtension = r.notes.value("barycentrics", "") == "extension";
    const auto want = analytic::predict(name, g, device);
    ASSERT_EQ(want.size(), r.frame.passes.size()) << name;
    for (size_t i = 0; i < want.size(); ++i) {
      EXPECT_EQ(r.frame.passes[i].fragmentInvocations, want[i].fragments) << name << " " << want[i].name;
    }
    // Every shaded pixel found its triangle through draw id kMaxDraws - 1:
    // three index fetches per covered pixel.
    EXPECT_EQ(counted(passNamed(r, "shading"), "indices", false), 3 * g.covered) << name;
  }
}

TEST(VisibilityIdCapacity, OneDrawOverTheLimitIsRefused) {
  const uint32_t over = shaders::kMaxDraws + 1;
  const auto spec = planes(int(over), "front-to-back", 0.5);
  for (const char* name : kVisbuffers) {
    Rendered r = render(name, spec, kExtent, {}, 1, /*expectFailure=*/true);
    EXPECT_FALSE(r.ok) << name;
    EXPECT_EQ(r.error.rfind(name, 0), 0u) << r.error;
    EXPECT_TRUE(mentions(r.error, over)) << r.error;
    EXPECT_TRUE(mentions(r.error, shaders::kMaxDraws)) << r.error;
  }
  // The limit is the visibility id's: forward draws the same scene.
  Rendered forward = render("forward", spec, kExtent);
  EXPECT_TRUE(forward.ok) << forward.error;
  const analytic::Geometry g = analytic::geometryOf(spec, kExtent);
  EXPECT_EQ(passNamed(forward, "forward").fragmentInvocations, g.covered);  // front to back: the first layer
}

}  // namespace
}  // namespace tally::renderers
