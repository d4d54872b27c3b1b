// Capture specs: defaults, and a clear error naming the field for bad input.
#include <gtest/gtest.h>

#include "capture/spec.hpp"

namespace tally::capture {
namespace {

const std::vector<std::string> kRenderers = {"forward", "deferred", "visbuffer"};

Result<CaptureSpec> parse(const std::string& text) {
  return parseCaptureSpec(nlohmann::json::parse(text), kRenderers);
}

TEST(CaptureSpec, DefaultsFollowTheFoundingStudy) {
  auto spec = parse(R"({"renderers":["deferred","visbuffer"],"resolutions":[[320,180]]})");
  ASSERT_TRUE(spec.ok()) << spec.error();
  EXPECT_EQ(spec->frames, 20u);
  EXPECT_EQ(spec->countedFramesOrDefault(), 2u);  // counted_frames: 2, enough to see a count vary
  auto one = parse(R"({"renderers":["forward"],"resolutions":[[8,8]],"frames":1})");
  ASSERT_TRUE(one.ok()) << one.error();
  EXPECT_EQ(one->countedFramesOrDefault(), 1u);  // never more than the timed frames
  EXPECT_EQ(spec->lights, 400u);
  EXPECT_TRUE(spec->autoCameras);
  EXPECT_TRUE(spec->ceilings);  // measured unless the spec says "ceilings": false
  auto skip = parse(R"({"renderers":["forward"],"resolutions":[[8,8]],"ceilings":false})");
  ASSERT_TRUE(skip.ok()) << skip.error();
  EXPECT_FALSE(skip->ceilings);
  ASSERT_EQ(spec->modes.size(), 1u);
  // Not the study's: accumulate, the cheapest exact mode (docs/accuracy.md).
  EXPECT_EQ(spirv::toString(spec->modes[0]), "accumulate");
  ASSERT_EQ(spec->scenes.size(), 1u);
  EXPECT_EQ(spec->scenes[0], "atrium");
  EXPECT_EQ(spec->sampleCount(10), 20u);
}

TEST(CaptureSpec, FullSpec) {
  auto spec = parse(R"({"renderers":["forward"],"scenes":["atrium",{"name":"planes","layers":4,"order":"front-to-back"},
    {"gltf":"scenes/sponza/Sponza.gltf"}],"resolutions":[[1280,720],[1920,1080]],
    "cameras":[{"eye":[0,1,2],"target":[0,1,0],"fov_deg":50}],"frames":5,"counting":"sampled:16","lights":32})");
  ASSERT_TRUE(spec.ok()) << spec.error();
  EXPECT_EQ(spec->scenes.size(), 3u);
  EXPECT_EQ(spec->resolutions[1].width, 1920u);
  EXPECT_FALSE(spec->autoCameras);
  ASSERT_EQ(spec->cameras.size(), 1u);
  EXPECT_FLOAT_EQ(spec->cameras[0].fovDeg, 50.0f);
  ASSERT_EQ(spec->modes.size(), 1u);
  EXPECT_EQ(spec->modes[0].sampleRate, 16u);
  EXPECT_EQ(spec->lights, 32u);
}

// "footprint": absent or false is off (0), true the default block of 64
// bytes, 32, 64 or 128 that block size.
TEST(CaptureSpec, FootprintBlockSize) {
  struct Case {
    const char* footprint;  // nullptr: absent
    uint32_t blockBytes;
  };
  for (const Case& c : {Case{nullptr, 0}, Case{"false", 0}, Case{"true", 64}, Case{"32", 32}, Case{"64", 64},
                        Case{"128", 128}}) {
    std::string text = R"({"renderers":["forward"],"resolutions":[[8,8]])";
    if (c.footprint) text += std::string(R"(,"footprint":)") + c.footprint;
    auto spec = parse(text + "}");
    ASSERT_TRUE(spec.ok()) << spec.error();
    EXPECT_EQ(spec->footprintBlockBytes, c.blockBytes) << (c.footprint ? c.footprint : "absent");
  }
}

TEST(CaptureSpec, Labels) {
  auto spec = parse(R"({"renderers":["forward"],"resolutions":[[8,8]],
    "labels":{"commit":"4f2a9c1","branch":"feature/alerts","ci.job":"1234"}})");
  ASSERT_TRUE(spec.ok()) << spec.error();
  EXPECT_EQ(spec->labels, (std::map<std::string, std::string>{
                              {"commit", "4f2a9c1"}, {"branch", "feature/alerts"}, {"ci.job", "1234"}}));
  EXPECT_TRUE(parse(R"({"renderers":["forward"],"resolutions":[[8,8]]})")->labels.empty());
  std::string many = "{";
  for (size_t i = 0; i <= capture::kMaxLabels; ++i) many += (i ? "," : "") + std::string("\"k") + std::to_string(i) + "\":\"v\"";
  many += "}";
  const std::string longValue(capture::kMaxLabelValue + 1, 'x');
  const std::string longName(capture::kMaxLabelKey + 1, 'k');
  for (auto [labels, prefix] : std::vector<std::pair<std::string, std::string>>{
           {R"(["commit"])", "labels: must be an object"},
           {R"({"commit":3})", "labels.commit: must be a string"},
           {R"({"commit":""})", "labels.commit: must be 1 to 256 characters"},
           {"{\"commit\":\"" + longValue + "\"}", "labels.commit: must be 1 to 256 characters"},
           {R"({"commit":"a\nb"})", "labels.commit: must be 1 to 256 characters without control characters"},
           {R"({"bad key":"x"})", "labels: label name 'bad key' must be"},
           {"{\"" + longName + "\":\"x\"}", "labels: label name"},
           {many, "labels: at most 16 labels, got 17"}}) {
    auto bad = parse(R"({"renderers":["forward"],"resolutions":[[8,8]],"labels":)" + labels + "}");
    ASSERT_FALSE(bad.ok()) << labels;
    EXPECT_EQ(bad.error().rfind(prefix, 0), 0u) << bad.error();
  }
}

TEST(CaptureSpec, CountingModesAreAMatrixDimension) {
  auto spec = parse(R"({"renderers":["forward","deferred"],"resolutions":[[32,18]],
    "counting":["exact","subgroup","sampled:4","sampled:64"]})");
  ASSERT_TRUE(spec.ok()) << spec.error();
  ASSERT_EQ(spec->modes.size(), 4u);
  EXPECT_EQ(spec->modes[1].kind, spirv::CountMode::Subgroup);
  EXPECT_EQ(spec->modes[3].sampleRate, 64u);
  EXPECT_EQ(spec->sampleCount(10), 2u * 4u * 10u);
}

struct BadCase {
  const char* spec;
  const char* expected;  // the error must start with this (the field)
};

class BadSpec : public ::testing::TestWithParam<BadCase> {};

TEST_P(BadSpec, NamesTheField) {
  auto spec = parse(GetParam().spec);
  ASSERT_FALSE(spec.ok()) << GetParam().spec;
  EXPECT_EQ(spec.error().rfind(GetParam().expected, 0), 0u) << spec.error();
  EXPECT_EQ(spec.error().find('\n'), std::string::npos);
}

INSTANTIATE_TEST_SUITE_P(
    Cases, BadSpec,
    ::testing::Values(
        BadCase{R"([1,2])", "spec: must be a JSON object"},
        BadCase{R"({"resolutions":[[8,8]]})", "renderers: required"},
        BadCase{R"({"renderers":[],"resolutions":[[8,8]]})", "renderers: must be a non-empty array"},
        BadCase{R"({"renderers":["fwd"],"resolutions":[[8,8]]})", "renderers[0]: unknown renderer 'fwd'"},
        BadCase{R"({"renderers":["forward","forward"],"resolutions":[[8,8]]})",
                "renderers[1]: renderer 'forward' listed twice"},
        BadCase{R"({"renderers":["forward","deferred","forward"],"resolutions":[[8,8]]})",
                "renderers[2]: renderer 'forward' listed twice (a duplicate of renderers[0])"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"scenes":["atrium","atrium"]})",
                "scenes[1]: a duplicate of scenes[0]"},
        BadCase{
            R"({"renderers":["forward"],"resolutions":[[8,8]],"scenes":["sky","planes",{"name":"planes","layers":8}]})",
            "scenes[2]: a duplicate of scenes[1]"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8],[4,4],[8,8]]})",
                "resolutions[2]: a duplicate of resolutions[0]"},
        BadCase{
            R"({"renderers":["forward"],"resolutions":[[8,8]],"cameras":[{"eye":[0,0,1],"target":[0,0,0]},{"eye":[0,0,1],"target":[0,0,0],"label":"b"}]})",
            "cameras[1]: a duplicate of cameras[0]"},
        BadCase{R"({"renderers":[3],"resolutions":[[8,8]]})", "renderers[0]: must be a renderer name"},
        BadCase{R"({"renderers":["forward"]})", "resolutions: required"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[0,8]]})",
                "resolutions[0][0]: must be an integer between 1 and 16384"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8],[640,"x"]]})",
                "resolutions[1][1]: must be an integer"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[640]]})",
                "resolutions[0]: must be [width, height]"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[16384,16384]]})",
                "resolutions[0]: 16384x16384 is more than"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"scenes":["mars"]})", "scenes[0]: "},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"scenes":[{"name":"planes","layers":0}]})",
                "scenes[0]: layers: "},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"scenes":[{"gltf":""}]})",
                "scenes[0].gltf: must be a file path"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"cameras":"random"})",
                "cameras: must be \"auto\""},
        BadCase{
            R"({"renderers":["forward"],"resolutions":[[8,8]],"cameras":[{"eye":[1,2],"target":[0,0,0]}]})",
            "cameras[0].eye"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"frames":0})",
                "frames: must be an integer between 1 and 1000"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"frames":4,"counted_frames":5})",
                "counted_frames: must be an integer between 1 and 4"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"counted_frames":0})",
                "counted_frames: must be an integer between 1 and 20"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"counting":"fast"})",
                "counting: unknown mode 'fast'"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"counting":"sampled:1"})",
                "counting: mode 'sampled:1'"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"counting":["exact","subgroup","fast"]})",
                "counting[2]: unknown mode 'fast'"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"counting":["exact",4]})",
                "counting[1]: must be a string"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"counting":["sampled:4","sampled:4"]})",
                "counting[1]: mode 'sampled:4' listed twice"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"counting":[]})",
                "counting: must be a mode or a non-empty array"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"counting":7})",
                "counting: must be a mode or a non-empty array"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"lights":401})",
                "lights: must be an integer between 0 and 400"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"frame":20})", "frame: unknown field"},
        // Footprint: a flag or one of the three block sizes.
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"footprint":48})",
                "footprint: must be true, false or a block size of 32, 64 or 128 bytes, got 48"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"footprint":"64"})",
                "footprint: must be true, false or a block size of 32, 64 or 128 bytes, got \"64\""},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"footprint":64.5})",
                "footprint: must be true, false"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"footprint":null})",
                "footprint: must be true, false"},
        BadCase{R"({"renderers":["forward"],"resolutions":[[8,8]],"ceilings":"yes"})",
                "ceilings: must be true or false, got \"yes\""},
        // Variants: {"renderer", "options"} entries.
        BadCase{R"({"renderers":[{"options":{}}],"resolutions":[[8,8]]})", "renderers[0].renderer: required"},
        BadCase{R"({"renderers":[{"renderer":"fwd"}],"resolutions":[[8,8]]})",
                "renderers[0].renderer: unknown renderer 'fwd'"},
        BadCase{R"({"renderers":[{"renderer":"visbuffer","option":{}}],"resolutions":[[8,8]]})",
                "renderers[0].option: unknown field"},
        BadCase{R"({"renderers":["forward",{"renderer":"visbuffer","options":[]}],"resolutions":[[8,8]]})",
                "renderers[1].options: must be an object"},
        BadCase{
            R"({"renderers":["forward",{"renderer":"visbuffer","options":{"barycentrics":"half"}}],"resolutions":[[8,8]]})",
            "renderers[1].options.barycentrics: \"half\" is not one of unorm16, float32"},
        BadCase{
            R"({"renderers":["forward",{"renderer":"deferred","options":{"barycentrics":"float32"}}],"resolutions":[[8,8]]})",
            "renderers[1].options.barycentrics: deferred takes no option barycentrics"},
        // The same canonical options twice: the default value written out is the renderer as it is.
        BadCase{
            R"({"renderers":["visbuffer",{"renderer":"visbuffer","options":{"barycentrics":"unorm16"}}],"resolutions":[[8,8]]})",
            "renderers[1]: renderer 'visbuffer' listed twice"},
        BadCase{
            R"({"renderers":[{"renderer":"visbuffer","options":{"barycentrics":"float32"}},{"renderer":"visbuffer","options":{"barycentrics":"float32"}}],"resolutions":[[8,8]]})",
            "renderers[1]: renderer 'visbuffer barycentrics=float32' listed twice"}));

TEST(CaptureSpec, VariantsAreCanonical) {
  auto spec = parse(R"({"renderers":["visbuffer",{"renderer":"visbuffer","options":{"uv_derivatives":"float32",
    "barycentrics":"float32","material_selection":"nonuniform"}},{"renderer":"forward","options":{}}],"resolutions":[[8,8]]})");
  ASSERT_TRUE(spec.ok()) << spec.error();
  ASSERT_EQ(spec->renderers.size(), 3u);
  EXPECT_EQ(spec->renderers[0].name, "visbuffer");
  EXPECT_EQ(spec->renderers[0].options, nlohmann::json::object());
  EXPECT_EQ(spec->renderers[0].label(), "visbuffer");
  // material_selection's default is dropped; keys sorted.
  EXPECT_EQ(spec->renderers[1].options, nlohmann::json({{"barycentrics", "float32"}, {"uv_derivatives", "float32"}}));
  EXPECT_EQ(spec->renderers[1].label(), "visbuffer barycentrics=float32 uv_derivatives=float32");
  EXPECT_EQ(spec->renderers[2].name, "forward");
  EXPECT_EQ(spec->renderers[2].options, nlohmann::json::object());
  EXPECT_EQ(spec->sampleCount(10), 3u * 10u);
}

// Ten distinct scenes, within the list caps: the matrix grows by multiplying lists.
std::string tenScenes() {
  std::string scenes;
  for (int i = 1; i <= 10; ++i)
    scenes += (i > 1 ? "," : "") + std::string(R"({"name":"planes","layers":)") + std::to_string(i) + "}";
  return "[" + scenes + "]";
}

TEST(CaptureSpec, MatrixLimit) {
  std::string resolutions;
  for (int i = 1; i <= 60; ++i)
    resolutions += (i > 1 ? "," : "") + std::string("[") + std::to_string(i) + ",8]";
  auto spec = parse(R"({"renderers":["forward","deferred"],"scenes":)" + tenScenes() + R"(,"resolutions":[)" +
                    resolutions + "]}");
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().find("12000 samples"), std::string::npos) << spec.error();
}

TEST(CaptureSpec, MatrixLimitCountsModes) {
  std::string resolutions;
  for (int i = 1; i <= 30; ++i)
    resolutions += (i > 1 ? "," : "") + std::string("[") + std::to_string(i) + ",8]";
  auto spec =
      parse(R"({"renderers":["forward"],"counting":["exact","subgroup","sampled:4","sampled:16"],"scenes":)" +
            tenScenes() + R"(,"resolutions":[)" + resolutions + "]}");
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().find("12000 samples"), std::string::npos) << spec.error();
}

}  // namespace
}  // namespace tally::capture

namespace tally::capture {
namespace {

// "heatmap" replaces "cameras": parsed by scenes::parseHeatmapSpec, its
// errors named from "heatmap", and every pose it may place counted in the
// matrix limit.
TEST(CaptureSpec, Heatmap) {
  auto spec = parse(R"({"renderers":["deferred","visbuffer"],"resolutions":[[64,36]],
    "heatmap":{"layout":"floor","cells":[4,3],"yaws":2}})");
  ASSERT_TRUE(spec.ok()) << spec.error();
  ASSERT_TRUE(spec->heatmap.has_value());
  EXPECT_FALSE(spec->autoCameras);
  EXPECT_EQ(spec->heatmap->columns, 4u);
  EXPECT_EQ(spec->heatmap->rows, 3u);
  EXPECT_EQ(spec->camerasPerScene(), 24u);
  EXPECT_EQ(spec->sampleCount(spec->camerasPerScene()), 48u);

  auto both = parse(R"({"renderers":["forward"],"resolutions":[[8,8]],"cameras":"auto","heatmap":{"layout":"sphere"}})");
  ASSERT_FALSE(both.ok());
  EXPECT_EQ(both.error().rfind("heatmap: cannot be combined with \"cameras\"", 0), 0u) << both.error();

  auto bad = parse(R"({"renderers":["forward"],"resolutions":[[8,8]],"heatmap":{"layout":"floor","cells":[4,0]}})");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("heatmap.cells[1]: must be an integer between 1 and 256, got 0", 0), 0u) << bad.error();

  // 100 x 100 cells x 1 yaw x 2 renderers = 20000 samples: over kMaxMatrix.
  auto big = parse(R"({"renderers":["deferred","visbuffer"],"resolutions":[[8,8]],
    "heatmap":{"layout":"floor","cells":[100,100],"yaws":1}})");
  ASSERT_FALSE(big.ok());
  EXPECT_EQ(big.error().rfind("spec: the matrix has 20000 samples", 0), 0u) << big.error();
}

}  // namespace
}  // namespace tally::capture
