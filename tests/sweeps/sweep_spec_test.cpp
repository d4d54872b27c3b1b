// Sweep specs: the {"sweep": NAME, ...} frame and the depth-reconstruction
// spec, each bad field named; the float32 depth-step formula against the
// float spacing itself.
#include <cmath>

#include <gtest/gtest.h>

#include "sweeps/sweep.hpp"

namespace tally::sweeps {
namespace {

using nlohmann::json;

const std::vector<std::string> kRenderers = {"forward", "deferred", "visbuffer"};

Result<SweepSpec> parse(const std::string& text) { return parseSweepSpec(json::parse(text), kRenderers); }

std::string errorOf(const std::string& text) {
  auto spec = parse(text);
  return spec ? "(no error)" : spec.error();
}

TEST(SweepSpec, DepthDefaultsAndAxes) {
  auto spec = parse(R"({"sweep":"depth-reconstruction","near":[0.1,1],"far_over_near":[100,1000],
                        "distances":[2,5],"threshold":{"relative":1e-3}})");
  ASSERT_TRUE(spec.ok()) << spec.error();
  const auto& depth = std::get<DepthSweepSpec>(*spec);
  EXPECT_EQ(depth.renderer, "deferred");
  EXPECT_EQ(depth.resolution.width, 64u);
  EXPECT_TRUE(depth.byRatio());
  EXPECT_TRUE(depth.relativeThreshold);
  EXPECT_DOUBLE_EQ(depth.threshold, 1e-3);
  auto ranges = depth.ranges();
  ASSERT_EQ(ranges.size(), 4u);
  EXPECT_DOUBLE_EQ(ranges[1].near, 0.1);
  EXPECT_DOUBLE_EQ(ranges[1].far, 100.0);  // 0.1 x 1000
  EXPECT_DOUBLE_EQ(ranges[2].far, 100.0);  // 1 x 100

  auto byFar = parse(R"({"sweep":"depth-reconstruction","near":[0.01],"far":[50],"distances":[2],
                         "resolution":[32,18],"fov_deg":90,"threshold":{"absolute":0.01}})");
  ASSERT_TRUE(byFar.ok()) << byFar.error();
  const auto& f = std::get<DepthSweepSpec>(*byFar);
  EXPECT_FALSE(f.byRatio());
  EXPECT_FALSE(f.relativeThreshold);
  EXPECT_EQ(f.resolution.height, 18u);
  EXPECT_DOUBLE_EQ(f.fovDeg, 90.0);
}

TEST(SweepSpec, BadSpecsNameTheField) {
  const std::string base = R"("near":[0.1],"far":[100],"distances":[2],"threshold":{"relative":1e-3})";
  auto with = [&](const std::string& extra) {
    return errorOf(R"({"sweep":"depth-reconstruction",)" + base + extra + "}");
  };
  EXPECT_EQ(with(""), "(no error)");
  EXPECT_TRUE(errorOf(R"({"sweep":"bary"})").starts_with("sweep: unknown sweep 'bary'")) << errorOf(R"({"sweep":"bary"})");
  EXPECT_TRUE(errorOf(R"({"sweep":3})").starts_with("sweep: must be a sweep name"));
  EXPECT_TRUE(with(R"(,"frames":2)").starts_with("frames: unknown field")) << with(R"(,"frames":2)");
  EXPECT_TRUE(with(R"(,"renderer":"visbuffer")").starts_with("renderer: 'visbuffer' does not reconstruct"));
  EXPECT_TRUE(with(R"(,"renderer":"nope")").starts_with("renderer: unknown renderer 'nope'"));
  EXPECT_TRUE(with(R"(,"far_over_near":[10])").starts_with("far: give exactly one of far and far_over_near"));
  EXPECT_TRUE(with(R"(,"resolution":[64])").starts_with("resolution: must be [width, height]"));
  EXPECT_TRUE(with(R"(,"resolution":[64,0])").starts_with("resolution[1]: must be an integer"));
  EXPECT_TRUE(with(R"(,"fov_deg":180)").starts_with("fov_deg: must be a number between 1 and 170"));

  auto only = [&](const std::string& body) { return errorOf(R"({"sweep":"depth-reconstruction",)" + body + "}"); };
  EXPECT_TRUE(only(R"("far":[100],"distances":[2],"threshold":{"relative":1e-3})").starts_with("near: required"));
  EXPECT_TRUE(only(R"("near":[0.1],"distances":[2],"threshold":{"relative":1e-3})").starts_with("far: give exactly"));
  EXPECT_TRUE(only(R"("near":[0.1],"far":[100],"threshold":{"relative":1e-3})").starts_with("distances: required"));
  EXPECT_TRUE(only(R"("near":[0.1],"far":[100],"distances":[2])").starts_with("threshold: required"));
  EXPECT_TRUE(only(R"("near":[0,1],"far":[100],"distances":[2],"threshold":{"relative":1e-3})")
                  .starts_with("near[0]: must be a finite number greater than 0"));
  EXPECT_TRUE(only(R"("near":[0.1],"far_over_near":[1],"distances":[2],"threshold":{"relative":1e-3})")
                  .starts_with("far_over_near[0]: must be a finite number greater than 1"));
  EXPECT_TRUE(only(R"("near":[0.1],"far":[100],"distances":[2,2],"threshold":{"relative":1e-3})")
                  .starts_with("distances[1]: 2 listed twice"));
  EXPECT_TRUE(only(R"("near":[0.1],"far":[100],"distances":[],"threshold":{"relative":1e-3})")
                  .starts_with("distances: must be an array of 1 to"));
  // The tilted plane spans distance / (1 +- 0.1): 95 reaches beyond far = 100.
  EXPECT_TRUE(only(R"("near":[0.1],"far":[100],"distances":[2,95],"threshold":{"relative":1e-3})")
                  .starts_with("distances[1]: the plane at 95 spans view depths"));
  EXPECT_TRUE(only(R"("near":[1],"far":[0.5],"distances":[2],"threshold":{"relative":1e-3})")
                  .starts_with("far: far 0.5 is not beyond near 1"));
  EXPECT_TRUE(only(R"("near":[0.1],"far":[100],"distances":[2],"threshold":{"relative":2})")
                  .starts_with("threshold.relative: must be a number in (0, 1)"));
  EXPECT_TRUE(only(R"("near":[0.1],"far":[100],"distances":[2],"threshold":{"rel":0.1})")
                  .starts_with("threshold: must be {\"relative\": x}"));
  EXPECT_TRUE(only(R"("near":[0.1],"far":[100],"distances":[2],"threshold":{"relative":0.1,"absolute":1})")
                  .starts_with("threshold: must be"));
}

// The formula's depth step against the float32 spacing itself: the next float
// above D(t), mapped back to view depth through the inverse of D.
TEST(DepthSweep, StepMatchesTheFloatSpacing) {
  const double n = 0.1, f = 1000;
  EXPECT_DOUBLE_EQ(depthOf(n, n, f), 0.0);
  EXPECT_DOUBLE_EQ(depthOf(f, n, f), 1.0);
  for (double t : {0.5, 3.0, 30.0, 300.0}) {
    SCOPED_TRACE(t);
    float d = float(depthOf(t, n, f));
    double next = double(std::nextafter(d, 2.0f));
    auto viewDepth = [&](double depth) { return n * f / (f - depth * (f - n)); };  // inverse of depthOf
    double spacing = viewDepth(next) - viewDepth(double(d));
    // Along the view axis the ray length is t itself.
    EXPECT_NEAR(depthStepDistance(t, t, n, f), spacing, spacing * 0.01);
    // Along a slanted ray the step scales with the ray length.
    EXPECT_DOUBLE_EQ(depthStepDistance(t, 2 * t, n, f), 2 * depthStepDistance(t, t, n, f));
  }
}

}  // namespace
}  // namespace tally::sweeps
