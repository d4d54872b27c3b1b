// The visbuffer-precision sweep: spec errors name the field; the encodings'
// names; the analytic bounds against glm's own packing of many values; the
// texture's levels differ; and on lavapipe: the reference against itself is
// exact, the default encoding keeps today's formats and counts (and the
// float32 ones change only the element sizes), unorm16 barycentrics stay
// within their bound and grow with the triangle, the study's clamped
// derivatives break where the uv rotation makes components negative and not
// where it keeps them positive, half derivatives stay within their bound,
// and fails_at names the first failing point.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "sweeps/precision.hpp"
#include "sweeps/sweep.hpp"
#include "renderers/gpu_scene.hpp"
#include "renderers/renderer.hpp"
#include "sweep_fixture.hpp"

namespace tally::sweeps {
namespace {

using nlohmann::json;
using renderers::BarycentricEncoding;
using renderers::UvDerivativeEncoding;

std::string errorOf(const json& spec) {
  auto parsed = parseSweepSpec(spec, renderers::rendererNames());
  return parsed ? "(no error)" : parsed.error();
}

json precisionSpec(json extra = json::object()) {
  json spec = {{"sweep", "visbuffer-precision"},
               {"distances", {4}},
               {"triangle_sizes", {1}},
               {"resolution", {48, 32}}};
  for (auto& [k, v] : extra.items()) spec[k] = v;
  return spec;
}

json sweep(const json& spec) { return fixture::runSpec(spec); }

const json& point(const json& result, const std::string& variant, double distance, double size) {
  for (const auto& p : result["points"]) {
    if (p["variant"] == variant && p["distance"] == distance && p["triangle_size"] == size) return p;
  }
  static const json none;
  ADD_FAILURE() << "no point " << variant << " distance " << distance << " size " << size;
  return none;
}

::testing::AssertionResult startsWith(const std::string& error, const std::string& prefix) {
  return ::testing::AssertionResult(error.rfind(prefix, 0) == 0) << error;
}

TEST(PrecisionSweepSpec, Defaults) {
  auto parsed = parseSweepSpec(precisionSpec({{"resolution", {96, 64}}}), renderers::rendererNames());
  ASSERT_TRUE(parsed.ok()) << parsed.error();
  const auto& spec = std::get<PrecisionSweepSpec>(*parsed);
  EXPECT_EQ(spec.textureSize, 1024u);
  EXPECT_EQ(spec.levels(), 11u);  // 1024 .. 1
  EXPECT_EQ(spec.texelsPerMetre, 256.0);
  EXPECT_EQ(spec.uvRotationDeg, 30.0);
  EXPECT_EQ(spec.fovDeg, 60.0);
  EXPECT_EQ(spec.imageThreshold, 8.0);
  EXPECT_EQ(spec.mipThreshold, 0.5);
  EXPECT_EQ(spec.resolution.width, 96u);
  EXPECT_EQ(spec.resolution.height, 64u);
  const auto names = sweepNames();
  EXPECT_NE(std::find(names.begin(), names.end(), "visbuffer-precision"), names.end());
}

TEST(PrecisionSweepSpec, BadSpecsNameTheField) {
  auto with = [](json extra) { return errorOf(precisionSpec(std::move(extra))); };
  EXPECT_EQ(with(json::object()), "(no error)");
  EXPECT_TRUE(startsWith(with({{"renderer", "visbuffer"}}), "renderer: unknown field"));
  EXPECT_TRUE(startsWith(errorOf({{"sweep", "visbuffer-precision"}, {"triangle_sizes", {1}}}),
                         "distances: required"));
  EXPECT_TRUE(startsWith(errorOf({{"sweep", "visbuffer-precision"}, {"distances", {1}}}),
                         "triangle_sizes: required"));
  EXPECT_TRUE(startsWith(with({{"distances", {1, 0}}}), "distances[1]: must be a number in (0, 1e6]"));
  EXPECT_TRUE(startsWith(with({{"distances", {2, 2}}}), "distances[1]: 2 listed twice"));
  EXPECT_TRUE(startsWith(with({{"distances", json::array()}}), "distances: must be an array of 1 to 64"));
  EXPECT_TRUE(startsWith(with({{"triangle_sizes", {"big"}}}), "triangle_sizes[0]: must be a number"));
  EXPECT_TRUE(
      startsWith(with({{"texture_size", 1000}}), "texture_size: must be a power of two from 16 to 8192"));
  EXPECT_TRUE(startsWith(with({{"texture_size", 8}}), "texture_size: must be a power of two"));
  EXPECT_TRUE(startsWith(with({{"texture_size", 16384}}), "texture_size: must be a power of two"));
  EXPECT_TRUE(startsWith(with({{"texture_size", 64.5}}), "texture_size: must be a power of two"));
  EXPECT_TRUE(
      startsWith(with({{"texels_per_metre", 0}}), "texels_per_metre: must be a number in (0, 1e+06]"));
  EXPECT_TRUE(
      startsWith(with({{"uv_rotation_deg", 400}}), "uv_rotation_deg: must be a number in [-360, 360]"));
  EXPECT_TRUE(startsWith(with({{"uv_rotation_deg", "30"}}), "uv_rotation_deg: must be a number"));
  EXPECT_TRUE(startsWith(with({{"resolution", {0, 32}}}), "resolution[0]: must be an integer"));
  EXPECT_TRUE(startsWith(with({{"resolution", {32}}}), "resolution: must be [width, height]"));
  EXPECT_TRUE(startsWith(with({{"fov_deg", 0}}), "fov_deg: must be a number in [1, 170]"));
  EXPECT_TRUE(startsWith(with({{"threshold", 8}}), "threshold: must be {\"image_max_abs\""));
  EXPECT_TRUE(startsWith(with({{"threshold", {{"relative", 0.1}}}}), "threshold.relative: unknown field"));
  EXPECT_TRUE(startsWith(with({{"threshold", {{"image_max_abs", 0}}}}), "threshold.image_max_abs: must be"));
  EXPECT_TRUE(startsWith(with({{"threshold", {{"mip_level", -1}}}}), "threshold.mip_level: must be"));
  // 10 x 8 points x 7 renders (reference + 6 compared) = 560 > 512.
  json many = precisionSpec(
      {{"distances", {1, 2, 3, 4, 5, 6, 7, 8, 9, 10}}, {"triangle_sizes", {1, 2, 3, 4, 5, 6, 7, 8}}});
  EXPECT_TRUE(startsWith(errorOf(many), "spec: distances x triangle_sizes x 7 encodings is 560 renders"));
  // 1 cm legs at 100 m: the plane is ~190 x ~130 m, 2 x 19000 x 13000 triangles.
  const std::string tiny = with({{"distances", {100}}, {"triangle_sizes", {1, 0.01}}});
  EXPECT_TRUE(startsWith(tiny, "triangle_sizes[1]: legs of 0.01 m tile the plane at distance 100")) << tiny;
  EXPECT_NE(tiny.find(std::to_string(kMaxPrecisionTriangles)), std::string::npos) << tiny;
}

TEST(VisibilityEncoding, NamesRoundTrip) {
  for (auto e : {BarycentricEncoding::Unorm16, BarycentricEncoding::Float32}) {
    EXPECT_EQ(renderers::parseBarycentricEncoding(renderers::toString(e)), e);
  }
  for (auto e :
       {UvDerivativeEncoding::Half, UvDerivativeEncoding::Unorm16Clamped, UvDerivativeEncoding::Float32}) {
    EXPECT_EQ(renderers::parseUvDerivativeEncoding(renderers::toString(e)), e);
  }
  EXPECT_EQ(renderers::toString(UvDerivativeEncoding::Unorm16Clamped), "unorm16-clamped");
  EXPECT_FALSE(renderers::parseBarycentricEncoding("half").has_value());
  EXPECT_FALSE(renderers::parseUvDerivativeEncoding("unorm16").has_value());
  // The default is the renderer's own packing.
  const renderers::VisibilityEncoding defaults;
  EXPECT_EQ(defaults.barycentrics, BarycentricEncoding::Unorm16);
  EXPECT_EQ(defaults.uvDerivatives, UvDerivativeEncoding::Half);
}

TEST(PrecisionBounds, MipLevelOf) {
  const double t = 1024;
  EXPECT_DOUBLE_EQ(mipLevelOf({4 / t, 0}, {0, 1 / t}, 1024, 11), 2.0);  // the longer vector
  EXPECT_DOUBLE_EQ(mipLevelOf({0, 3 / t}, {-4 / t, 3 / t}, 1024, 11),
                   std::log2(5.0));                                    // lengths, not components
  EXPECT_DOUBLE_EQ(mipLevelOf({0.25 / t, 0}, {0, 0}, 1024, 11), 0.0);  // magnified: clamped to 0
  EXPECT_DOUBLE_EQ(mipLevelOf({0, 0}, {0, 0}, 1024, 11), 0.0);         // log2 0 = -inf, clamped
  EXPECT_DOUBLE_EQ(mipLevelOf({2, 0}, {0, 0}, 1024, 11), 10.0);        // beyond the 1x1 level
}

// The bounds against glm's packing (a second implementation of the GLSL
// functions), over many values.
TEST(PrecisionBounds, HoldForGlmPacking) {
  uint32_t state = 12345;
  auto next = [&] {
    state = state * 1664525u + 1013904223u;
    return double(state >> 8) / double(1u << 24);
  };
  double worstBary = 0;
  for (int i = 0; i < 200000; ++i) {
    const glm::vec2 b{float(next()), float(next())};
    const glm::vec2 back = glm::unpackUnorm2x16(glm::packUnorm2x16(b));
    worstBary = std::max({worstBary, std::abs(double(back.x) - b.x), std::abs(double(back.y) - b.y)});
  }
  EXPECT_LE(worstBary, unorm16BarycentricBound());
  EXPECT_GT(worstBary, 0.9 * 0.5 / 65535.0);  // and the bound is nearly reached

  for (uint32_t size : {1024u, 8192u}) {
    SCOPED_TRACE(size);
    const uint32_t levels = uint32_t(std::log2(size)) + 1;
    double worst = 0;
    for (int i = 0; i < 200000; ++i) {
      // Lengths from 1 to 2^12 texels (level 0 to 12), any direction and sign.
      const double len = std::exp2(next() * 12.0) / size, angle = next() * 6.283185307179586;
      const glm::vec2 dx{float(len * std::cos(angle)), float(len * std::sin(angle))};
      const glm::vec2 dy{float(-dx.y * (0.5 + next())), float(dx.x * (0.5 + next()))};
      const glm::vec2 hx = glm::unpackHalf2x16(glm::packHalf2x16(dx)),
                      hy = glm::unpackHalf2x16(glm::packHalf2x16(dy));
      worst = std::max(worst, std::abs(mipLevelOf(hx, hy, size, levels) - mipLevelOf(dx, dy, size, levels)));
    }
    EXPECT_LE(worst, halfMipLevelBound(size));
    EXPECT_GT(worst, 0.5 * -std::log2(1.0 - std::ldexp(1.0, -11)));
  }
  // The closed forms: 11 significant bits; subnormals widen it at 8192.
  EXPECT_NEAR(halfMipLevelBound(1024), -std::log2(1.0 - std::ldexp(1.0, -11)), 2e-6);
  EXPECT_NEAR(barycentricUvBound({0.25, 0}, {0, 0.5}, 1024), unorm16BarycentricBound() * 0.75 * 1024, 1e-12);
}

TEST(PrecisionTexture, EveryLevelItsOwnColour) {
  const scenes::Texture t = precisionTexture(64);
  ASSERT_EQ(t.mips.size(), 6u);  // 32, 16, 8, 4, 2, 1
  std::vector<glm::dvec3> means;
  for (uint32_t level = 0; level <= t.mips.size(); ++level) {
    const auto& texels = level == 0 ? t.rgba8 : t.mips[level - 1];
    const uint32_t n = std::max(64u >> level, 1u);
    ASSERT_EQ(texels.size(), size_t(n) * n * 4) << level;
    glm::dvec3 sum(0.0);
    for (size_t i = 0; i < texels.size(); i += 4) sum += glm::dvec3(texels[i], texels[i + 1], texels[i + 2]);
    means.push_back(sum / double(n * n));
    // Neighbouring texels of a level differ strongly (the checker).
    if (n > 1) {
      EXPECT_GT(std::abs(int(texels[0]) + texels[1] + texels[2] - texels[4] - texels[5] - texels[6]), 100);
    }
  }
  // A box filter of level L would keep its mean colour; these levels change it.
  for (size_t level = 1; level < means.size(); ++level) {
    EXPECT_GT(glm::length(means[level] - means[level - 1]), 60.0) << level;
  }
}

TEST(PrecisionSweep, ReferenceAgainstItselfIsExact) {
  json result = sweep(precisionSpec());
  ASSERT_FALSE(result.is_null());
  EXPECT_EQ(result["sweep"], "visbuffer-precision");
  EXPECT_EQ(result["parameters"], json({"distance", "triangle_size", "variant"}));
  EXPECT_EQ(result["method"]["formats"]["tally"]["visibility.id"], "R32G32_UINT");
  ASSERT_EQ(result["points"].size(), precisionVariants().size());
  const json& p = point(result, "reference", 4, 1);
  EXPECT_EQ(p["pixels"], 48 * 32);
  EXPECT_EQ(p["id_mismatches"], 0);
  EXPECT_EQ(p["error"]["image"]["max_abs"], 0);
  EXPECT_EQ(p["error"]["image"]["differing_fraction"], 0.0);
  EXPECT_TRUE(p["error"]["image"]["psnr"].is_null());  // identical: +infinity
  EXPECT_EQ(p["error"]["mip_level"]["max_abs"], 0.0);
  EXPECT_EQ(p["error"]["uv_texels"]["max"], 0.0);
  EXPECT_EQ(p["fails"], json::array());
  // Every point holds every field a plot names.
  for (const auto& plot : result["plots"]) {
    for (const auto& q : result["points"]) {
      for (std::string path : {plot["x"].get<std::string>(), plot["y"].get<std::string>()}) {
        const json* at = &q;
        for (size_t start = 0; start <= path.size();) {
          size_t dot = std::min(path.find('.', start), path.size());
          const std::string key = path.substr(start, dot - start);
          ASSERT_TRUE(at->contains(key)) << path;
          at = &(*at)[key];
          start = dot + 1;
        }
        EXPECT_TRUE(at->is_number()) << path;
      }
      for (const auto& s : plot["series"]) EXPECT_TRUE(q.contains(s.get<std::string>()));
    }
  }
}

// Renders the sweep's scene once per encoding, instrumented, on one device.
struct EncodedFrame {
  renderers::FrameResult frame;
  std::vector<renderers::ResourceInfo> resources;
  json notes;
  std::vector<uint8_t> image;  // RGBA8
};

const renderers::ResourceInfo* resource(const EncodedFrame& f, const std::string& name) {
  for (const auto& r : f.resources) {
    if (r.name == name) return &r;
  }
  return nullptr;
}

// The sweep's scene at `distance` (1 m legs), rendered by an instrumented
// visbuffer once per encoding.
Result<json> renderEncodings(const PrecisionSweepSpec& spec, double distance,
                             const std::vector<renderers::VisibilityEncoding>& encodings,
                             std::vector<EncodedFrame>& frames) {
  return gpu::withDevice("", [&](gpu::Context& ctx) -> Result<json> {
    auto scene = precisionScene(spec, distance, 1.0);
    if (!scene) return makeError(scene.error());
    renderers::GpuScene gpuScene;
    if (auto ok = gpuScene.upload(ctx, *scene); !ok) return makeError(ok.error());
    for (const auto& e : encodings) {
      auto made = renderers::makeRenderer("visbuffer");
      if (!made) return makeError(made.error());
      renderers::RendererOptions options;
      options.extent = {spec.resolution.width, spec.resolution.height};
      options.lights = 0;
      options.visibility = e;
      if (auto ok = (*made)->setup(ctx, gpuScene, options); !ok) return makeError(ok.error());
      EncodedFrame f;
      f.frame = (*made)->renderFrame(precisionCamera(spec));
      f.resources = (*made)->resources();
      f.notes = (*made)->notes();
      f.image = (*made)->finalImage();
      (*made)->destroy();
      frames.push_back(std::move(f));
    }
    gpuScene.destroy();
    return json::object();
  });
}

// The texture's own levels reach the sampler (GpuScene uploads
// Texture::mips, on the map-array path too): at level 3 the image is level
// 3's yellow (1, 1, 0.16), where box-filtered levels would keep level 0's red.
TEST(PrecisionSweep, TheTexturesOwnLevelsAreSampled) {
  auto parsed = parsePrecisionSweepSpec(precisionSpec({{"texture_size", 256}, {"resolution", {32, 24}}}));
  ASSERT_TRUE(parsed.ok()) << parsed.error();
  // 2^3 texels per pixel at the centre: 2 d tan 30 / 24 x 256 = 8.
  const double distance = 8.0 * 24.0 / (2.0 * std::tan(glm::radians(30.0)) * 256.0);
  std::vector<EncodedFrame> frames;
  auto ran = renderEncodings(*parsed, distance, {{}}, frames);
  ASSERT_TRUE(ran.ok()) << ran.error();
  ASSERT_EQ(frames.size(), 1u);
  glm::dvec3 sum(0.0);
  for (size_t i = 0; i < frames[0].image.size(); i += 4) {
    sum += glm::dvec3(frames[0].image[i], frames[0].image[i + 1], frames[0].image[i + 2]);
  }
  // Yellow: G as R, B well below (lavapipe: G / R 0.98, B / R 0.25). Red
  // would give G as low as B.
  EXPECT_GT(sum.g, 0.8 * sum.r);
  EXPECT_LT(sum.b, 0.7 * sum.r);
}

// GpuScene refuses a texture whose own levels do not fit its size, naming it.
TEST(PrecisionSweep, ExplicitMipsMustFitTheTexture) {
  auto parsed = parsePrecisionSweepSpec(precisionSpec({{"texture_size", 16}}));
  ASSERT_TRUE(parsed.ok()) << parsed.error();
  auto ran = gpu::withDevice("", [&](gpu::Context& ctx) -> Result<json> {
    auto scene = precisionScene(*parsed, 4.0, 1.0);
    if (!scene) return makeError(scene.error());
    json errors = json::array();
    renderers::GpuScene gpuScene;
    scene->textures[0].mips[1].pop_back();  // level 2: 4x4 texels, one byte short
    auto shortLevel = gpuScene.upload(ctx, *scene);
    errors.push_back(shortLevel ? "(no error)" : shortLevel.error());
    scene->textures[0].mips.pop_back();  // the 1x1 level missing
    auto missing = gpuScene.upload(ctx, *scene);
    errors.push_back(missing ? "(no error)" : missing.error());
    gpuScene.destroy();
    return errors;
  });
  ASSERT_TRUE(ran.ok()) << ran.error();
  EXPECT_EQ((*ran)[0], "texture 'precision/diffuse': mips[1] (level 2) has 63 bytes, expected 64");
  EXPECT_EQ((*ran)[1], "texture 'precision/diffuse': mips has 3 levels, a 16x16 texture has 4 below level 0");
}

TEST(PrecisionSweep, DefaultEncodingKeepsFormatsAndCounts) {
  auto parsed = parsePrecisionSweepSpec(precisionSpec({{"texture_size", 64}, {"resolution", {32, 24}}}));
  ASSERT_TRUE(parsed.ok()) << parsed.error();
  const PrecisionSweepSpec spec = *parsed;
  std::vector<renderers::VisibilityEncoding> encodings = {
      {},  // default-constructed
      {BarycentricEncoding::Float32, UvDerivativeEncoding::Float32},
      {BarycentricEncoding::Unorm16, UvDerivativeEncoding::Unorm16Clamped}};
  std::vector<EncodedFrame> frames;
  auto ran = renderEncodings(spec, 4.0, encodings, frames);
  ASSERT_TRUE(ran.ok()) << ran.error();
  ASSERT_EQ(frames.size(), 3u);

  // Today's fat visibility buffer: two R32G32_UINT targets (visbuffer.cpp, the
  // founding study's layout), one texel written per fragment and read per
  // covered pixel (the plane covers all 32 x 24).
  const EncodedFrame& base = frames[0];
  EXPECT_EQ(base.notes["visibility_encoding"],
            json({{"barycentrics", "unorm16"}, {"uv_derivatives", "half"}}));
  for (const char* name : {"visibility.id", "visibility.uv_derivatives"}) {
    const auto* r = resource(base, name);
    ASSERT_NE(r, nullptr) << name;
    EXPECT_EQ(r->formatName, "R32G32_UINT");
    EXPECT_EQ(r->elementBytes, 8u);
  }
  ASSERT_EQ(base.frame.passes.size(), 4u);  // visibility, shading, tonemap, skybox
  const auto& visibility = base.frame.passes[0];
  const auto& shading = base.frame.passes[1];
  EXPECT_EQ(visibility.name, "visibility");
  EXPECT_GE(visibility.fragmentInvocations, 32u * 24u);
  for (const char* name : {"visibility.id", "visibility.uv_derivatives"}) {
    SCOPED_TRACE(name);
    bool written = false, read = false;
    for (const auto& a : visibility.accesses) {
      if (a.resource == name && a.write) {
        written = true;
        EXPECT_EQ(a.count, visibility.fragmentInvocations);
        EXPECT_EQ(a.bytes, a.count * 8);
      }
    }
    for (const auto& a : shading.accesses) {
      if (a.resource == name && !a.write) {
        read = true;
        EXPECT_EQ(a.count, 32u * 24u);
        EXPECT_EQ(a.bytes, a.count * 8);
      }
    }
    EXPECT_TRUE(written && read);
  }

  // Other encodings: the same events, bytes by their element size; float32
  // ids are 12 bytes (RGB32) or 16 where the device cannot render to RGB32.
  const auto* floatId = resource(frames[1], "visibility.id");
  ASSERT_NE(floatId, nullptr);
  EXPECT_TRUE(floatId->formatName == "R32G32B32_UINT" || floatId->formatName == "R32G32B32A32_UINT");
  EXPECT_EQ(floatId->elementBytes, floatId->formatName == "R32G32B32_UINT" ? 12u : 16u);
  EXPECT_EQ(resource(frames[1], "visibility.uv_derivatives")->formatName, "R32G32B32A32_UINT");
  EXPECT_EQ(resource(frames[2], "visibility.uv_derivatives")->formatName, "R32G32_UINT");
  for (size_t f = 1; f < frames.size(); ++f) {
    SCOPED_TRACE(frames[f].notes.dump());
    ASSERT_EQ(frames[f].frame.passes.size(), base.frame.passes.size());
    for (size_t p = 0; p < base.frame.passes.size(); ++p) {
      const auto& want = base.frame.passes[p];
      const auto& got = frames[f].frame.passes[p];
      EXPECT_EQ(got.fragmentInvocations, want.fragmentInvocations) << want.name;
      ASSERT_EQ(got.accesses.size(), want.accesses.size()) << want.name;
      for (size_t a = 0; a < want.accesses.size(); ++a) {
        SCOPED_TRACE(want.name + " " + want.accesses[a].resource);
        EXPECT_EQ(got.accesses[a].resource, want.accesses[a].resource);
        EXPECT_EQ(got.accesses[a].count, want.accesses[a].count);
        const auto* r = resource(frames[f], got.accesses[a].resource);
        if (got.accesses[a].resource.rfind("visibility.", 0) == 0) {
          ASSERT_NE(r, nullptr);
          EXPECT_EQ(got.accesses[a].bytes, got.accesses[a].count * r->elementBytes);
        } else {
          EXPECT_EQ(got.accesses[a].bytes, want.accesses[a].bytes);
        }
      }
    }
  }
}

// Legs 0.5 and 4 m (ratio 8) at 4 m, uv scale 256 texels per metre.
TEST(PrecisionSweep, Unorm16BarycentricsWithinTheirBoundAndGrowWithTheTriangle) {
  json result = sweep(precisionSpec({{"triangle_sizes", {0.5, 4}}}));
  ASSERT_FALSE(result.is_null());
  std::map<double, json> uv;
  for (double size : {0.5, 4.0}) {
    SCOPED_TRACE(size);
    // The grid's triangles have legs L along x and y; the index order puts
    // vertex 0 at a corner with one leg and the hypotenuse: |e1| + |e2| =
    // (1 + sqrt 2) L, times 256 texels per metre. Rounding: half a step of
    // 1/65535 plus float's 2^-24 in b x 65535.
    const double bound = (0.5 / 65535.0 + std::ldexp(1.0, -24)) * (1.0 + std::sqrt(2.0)) * size * 256.0;
    for (const char* variant : {"unorm16-barycentrics", "tally", "study"}) {
      const json& p = point(result, variant, 4, size);
      EXPECT_NEAR(p["predicted"]["uv_texels"]["max"].get<double>(), bound, 1e-6 * bound) << variant;
      EXPECT_LE(p["error"]["uv_texels"]["max_in_range"].get<double>(), bound) << variant;
      EXPECT_GT(p["error"]["uv_texels"]["max_in_range"].get<double>(), 0.5 * bound) << variant;
      // Pixels whose float barycentrics fall outside [0, 1] are few.
      EXPECT_LT(p["error"]["uv_texels"]["out_of_range_fraction"].get<double>(), 0.02) << variant;
    }
    for (const char* variant : {"reference", "half-derivatives", "study-derivatives"}) {
      EXPECT_EQ(point(result, variant, 4, size)["error"]["uv_texels"]["max"], 0.0) << variant;
    }
    uv[size] = point(result, "unorm16-barycentrics", 4, size)["error"]["uv_texels"];
  }
  // Rounding errors are uniform, so the mean grows as the edges do: x8.
  const double meanRatio = uv[4.0]["mean_in_range"].get<double>() / uv[0.5]["mean_in_range"].get<double>();
  EXPECT_NEAR(meanRatio, 8.0, 8.0 * 0.15);
  const double maxRatio = uv[4.0]["max_in_range"].get<double>() / uv[0.5]["max_in_range"].get<double>();
  EXPECT_NEAR(maxRatio, 8.0, 8.0 * 0.35);
}

// The derivative of u and v across one pixel at rotation r: d(uv)/dx =
// k (cos r, sin r), d(uv)/dy = k (-sin r, cos r), plus the tilt's
// perspective terms. Every component is >= 0 only at r = 0; at 180 degrees
// every one is negative, so the study's packing keeps only the perspective
// terms (under 10% of the length) and the level drops by log2(1/0.1) > 3
// (clamped at 0).
TEST(PrecisionSweep, StudyDerivativesBreakOnlyWhereComponentsAreNegative) {
  const json flipped = sweep(precisionSpec({{"uv_rotation_deg", 180}}));
  const json aligned = sweep(precisionSpec({{"uv_rotation_deg", 0}}));
  ASSERT_FALSE(flipped.is_null());
  ASSERT_FALSE(aligned.is_null());
  for (const char* variant : {"study-derivatives", "study"}) {
    SCOPED_TRACE(variant);
    const json& bad = point(flipped, variant, 4, 1);
    const double level = bad["level"].get<double>();  // log2(2 x 4 x tan 30 / 32 x 256) = 5.2
    EXPECT_GT(level, 5.0);
    EXPECT_GE(bad["error"]["mip_level"]["max_abs"].get<double>(), std::min(level, 3.3) - 0.2);
    EXPECT_GT(bad["error"]["mip_level"]["fraction_over_half"].get<double>(), 0.9);
    EXPECT_EQ(bad["error"]["mip_level"]["clamped_fraction"], 1.0);
    EXPECT_GE(bad["error"]["image"]["max_abs"].get<double>(), 8.0);
    EXPECT_NE(std::find(bad["fails"].begin(), bad["fails"].end(), "mip_level"), bad["fails"].end());
    // The model (ray-plane derivatives, packed) predicts the measured levels.
    EXPECT_NEAR(bad["error"]["mip_level"]["max_abs"].get<double>(),
                bad["predicted"]["mip_level"]["max_abs"].get<double>(), 0.05);

    // Rotation 0: only the perspective cross terms can be negative: d(v)/dx
    // below the centre row and d(u)/dy left of the centre column, so 3/4 of
    // the pixels lose one (to a row and a column of finite differences).
    const json& good = point(aligned, variant, 4, 1);
    EXPECT_NEAR(good["error"]["mip_level"]["clamped_fraction"].get<double>(), 0.75, 1.0 / 32 + 1.0 / 48);
    // A cross term is at most x b t / d of the length (x <= tan 30 x 1.5,
    // b = 0.05 / tan 30, t / d <= 1 / 0.9): dropping it shortens the vector
    // by a factor >= 1 / sqrt(1 + 0.0835^2). Quantisation: half a step per
    // component of a vector at least (level 5.2 - 0.2 tilt) 32 texels / 1024 long.
    const double cross = std::tan(glm::radians(30.0)) * 1.5 * (0.05 / std::tan(glm::radians(30.0))) / 0.9;
    const double quantised = 0.5 * std::sqrt(2.0) / 65535.0 / (std::exp2(5.0) / 1024.0);
    const double bound = 0.5 * std::log2(1.0 + cross * cross) - std::log2(1.0 - quantised);
    EXPECT_LE(good["error"]["mip_level"]["max_abs"].get<double>(), bound);
    EXPECT_EQ(good["error"]["mip_level"]["fraction_over_half"], 0.0);
    EXPECT_LT(good["error"]["image"]["max_abs"].get<double>(), 8.0);
    EXPECT_EQ(good["fails"], json::array());
  }
}

TEST(PrecisionSweep, HalfDerivativesWithinTheirBound) {
  const json result = sweep(precisionSpec({{"distances", {0.5, 32}}, {"uv_rotation_deg", 135}}));
  ASSERT_FALSE(result.is_null());
  // 11 significant bits, round to nearest: a length within 1 +- 2^-11; with
  // 1024 texels subnormal halves widen it by sqrt(1 + (1024 / 16384)^2).
  const double bound =
      -std::log2(1.0 - std::ldexp(1.0, -11) * std::sqrt(1.0 + std::pow(1024.0 / 16384.0, 2.0)));
  for (double distance : {0.5, 32.0}) {
    for (const char* variant : {"half-derivatives", "tally"}) {
      SCOPED_TRACE(std::string(variant) + " " + std::to_string(distance));
      const json& p = point(result, variant, distance, 1);
      EXPECT_LE(p["error"]["mip_level"]["max_abs"].get<double>(), bound);
      EXPECT_GT(p["error"]["mip_level"]["max_abs"].get<double>(), 0.0);  // packing did happen
      EXPECT_NEAR(p["predicted"]["mip_level"]["max_abs"].get<double>(), bound, 1e-9);
      EXPECT_EQ(p["error"]["mip_level"]["clamped_fraction"], 0.0);
    }
  }
}

// fails_at from the points, computed here independently: per (variant,
// triangle size) the smallest distance whose image or mip-level error
// reaches the threshold, and per (variant, distance) the smallest size.
TEST(PrecisionSweep, FailsAtIsTheFirstFailingPoint) {
  const json result = sweep(precisionSpec({{"distances", {0.25, 1, 4}},
                                           {"triangle_sizes", {1, 4}},
                                           {"uv_rotation_deg", 180},
                                           {"threshold", {{"image_max_abs", 8}, {"mip_level", 1.0}}}}));
  ASSERT_FALSE(result.is_null());
  ASSERT_TRUE(result["fails_at"].is_object());
  auto fails = [&](const json& p, std::vector<std::string>& metrics) {
    metrics.clear();
    if (p["error"]["image"]["max_abs"].get<double>() >= 8.0) metrics.push_back("image_max_abs");
    if (p["error"]["mip_level"]["max_abs"].get<double>() >= 1.0) metrics.push_back("mip_level");
    return !metrics.empty();
  };
  size_t failing = 0, passing = 0;
  for (const auto& [param, other] : {std::pair<std::string, std::string>{"distance", "triangle_size"},
                                     std::pair<std::string, std::string>{"triangle_size", "distance"}}) {
    const json& groups = result["fails_at"][param];
    ASSERT_TRUE(groups.is_array()) << param;
    // One group per variant and value of the other axis (2 sizes, 3 distances).
    EXPECT_EQ(groups.size(), precisionVariants().size() * (param == "distance" ? 2 : 3));
    for (const auto& g : groups) {
      SCOPED_TRACE(g.dump());
      double first = std::numeric_limits<double>::infinity();
      std::vector<std::string> firstMetrics, metrics;
      for (const auto& p : result["points"]) {
        if (p["variant"] != g["variant"] || p[other] != g[other]) continue;
        if (fails(p, metrics) && p[param].get<double>() < first) {
          first = p[param].get<double>();
          firstMetrics = metrics;
        }
      }
      if (std::isinf(first)) {
        ++passing;
        EXPECT_TRUE(g[param].is_null());
        EXPECT_TRUE(g["metrics"].is_null());
      } else {
        ++failing;
        EXPECT_EQ(g[param].get<double>(), first);
        EXPECT_EQ(g["metrics"], json(firstMetrics));
      }
    }
  }
  EXPECT_GT(failing, 0u);  // the study's derivatives fail at 180 degrees
  EXPECT_GT(passing, 0u);  // the reference never does
}

}  // namespace
}  // namespace tally::sweeps
