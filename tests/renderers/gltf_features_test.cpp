// glTF material features in every renderer, on small files the tests write
// (gltf_writer.hpp): alpha mask, alpha blend (sorted, its own pass), back-face
// culling per draw (doubleSided, negative scale), vertex colours, the second
// uv set, texture transforms, each texture's own sampler and emission.
//
// The scenes are built so the expected figures follow by hand: the camera
// sits at (0, 0, 1) looking down -Z with a 60 degree vertical field of view,
// so a quad in the plane z = 0 spanning half-height tan(30 deg) and
// half-width tan(30 deg) x W / H fills the view exactly; its u grows
// linearly across the screen (a plane parallel to the image plane), so pixel
// column i samples u = 0.5 + (i + 0.5 - W / 2) / (W x kMargin) with the quad
// widened by kMargin. A texture whose left half differs from its right half
// then splits the image at the centre column.
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "gltf_writer.hpp"
#include "render_fixture.hpp"

namespace tally::renderers {
using namespace fixture;
using tally::testing::GltfQuad;
using tally::testing::GltfWriter;
using tally::testing::quadFacingCamera;
namespace {

constexpr VkExtent2D kExtent = {64, 36};
constexpr uint64_t kPixels = 64 * 36;
constexpr uint64_t kLeftHalf = 32 * 36;  // columns 0..31
constexpr float kMargin = 1.01f;         // the full-view quad is 1% wider and taller than the view
const float kHalfHeight = std::tan(glm::radians(30.0f)) * kMargin;
const float kHalfWidth = kHalfHeight * float(kExtent.width) / float(kExtent.height);

const std::vector<std::string> kRenderers = {"forward", "forward-zprepass", "deferred", "visbuffer",
                                             "visbuffer-lean"};

// The pass that shades each covered pixel once (after the geometry pass).
std::string shadingPass(const std::string& renderer) {
  if (renderer == "deferred") return "lighting";
  if (renderer == "visbuffer" || renderer == "visbuffer-lean") return "shading";
  return "forward";  // forward-zprepass: depth EQUAL, one fragment per covered pixel
}

scenes::Camera frontCamera() {
  scenes::Camera c;
  c.eye = glm::vec3(0, 0, 1);
  c.target = glm::vec3(0, 0, 0);
  c.fovDeg = 60.0f;
  return c;
}

// A width x height texture whose columns left of the middle are `left` and the others `right`.
std::vector<uint8_t> halves(int width, int height, glm::u8vec4 left, glm::u8vec4 right) {
  std::vector<uint8_t> out;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const glm::u8vec4 c = x < width / 2 ? left : right;
      out.insert(out.end(), {c.r, c.g, c.b, c.a});
    }
  return out;
}

GltfQuad fullView(float z, int material) {
  return quadFacingCamera(-kHalfWidth, -kHalfHeight, kHalfWidth, kHalfHeight, z, material);
}

// Writes the file and returns its scene spec, with the test camera set.
nlohmann::json sceneOf(const GltfWriter& w, const std::string& name) {
  static const std::string dir = tally::testing::tempFolder("tally-gltf-features-");
  nlohmann::json spec = {{"gltf", w.write(dir, name)}};
  testScene(spec).camera = frontCamera();
  return spec;
}

struct Rgb {
  double r = 0, g = 0, b = 0;
};
// Mean colour of the columns [x0, x1) and rows [y0, y1) of an RGBA8 image of kExtent.
Rgb meanRect(const std::vector<uint8_t>& image, uint32_t x0, uint32_t x1, uint32_t y0, uint32_t y1) {
  Rgb m;
  double n = 0;
  for (uint32_t y = y0; y < y1; ++y)
    for (uint32_t x = x0; x < x1; ++x) {
      const uint8_t* p = &image[(size_t(y) * kExtent.width + x) * 4];
      m.r += p[0];
      m.g += p[1];
      m.b += p[2];
      n += 1;
    }
  m.r /= n;
  m.g /= n;
  m.b /= n;
  return m;
}
Rgb meanColumns(const std::vector<uint8_t>& image, uint32_t x0, uint32_t x1) {
  return meanRect(image, x0, x1, 0, kExtent.height);
}

// The image with nothing drawn: the sky of the same camera (an empty-looking
// scene: one quad far behind the camera).
std::vector<uint8_t> skyImage() {
  GltfWriter w;
  w.addQuad(quadFacingCamera(-0.1f, -0.1f, 0.1f, 0.1f, 5.0f, -1));  // behind the eye: never seen
  Rendered r = render("forward", sceneOf(w, "sky_only"), kExtent);
  EXPECT_TRUE(r.ok) << r.error;
  return r.image;
}

TEST(GltfAlphaMask, OnlyTexelsAboveTheCutoffCoverPixelsInEveryRenderer) {
  // Left half of the texture opaque, right half transparent; cutoff 0.5:
  // the left 32 columns pass (trilinear alpha at their u stays above 0.75),
  // the right 32 are discarded.
  GltfWriter w;
  const int t = w.addTexture(64, 64, halves(64, 64, {255, 255, 255, 255}, {255, 255, 255, 0}));
  const int m = w.addMaterial({{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", t}}},
                                                         {"baseColorFactor", {1.0, 0.1, 0.1, 1.0}}}},
                               {"alphaMode", "MASK"},
                               {"alphaCutoff", 0.5}});
  w.addQuad(fullView(0.0f, m));
  const nlohmann::json spec = sceneOf(w, "alpha_mask");
  const std::vector<uint8_t> sky = skyImage();
  const Rgb skyRight = meanColumns(sky, 32, 64);
  for (const auto& name : kRenderers) {
    Rendered r = render(name, spec, kExtent);
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    // Shading happens where the test passed: stencil (deferred, visbuffers)
    // and depth EQUAL (the pre-pass) carry the geometry pass's test.
    EXPECT_EQ(passNamed(r, shadingPass(name)).fragmentInvocations, name == "forward" ? kPixels : kLeftHalf)
        << name;
    if (name == "forward") {
      // Late tests: the shader runs on all 2304 covered pixels, and stores hdr on the 1152 it keeps.
      EXPECT_EQ(counted(passNamed(r, "forward"), "hdr", true), kLeftHalf);
    }
    // The image: the quad's red on the left, exactly the sky on the right.
    const Rgb left = meanColumns(r.image, 0, 32), right = meanColumns(r.image, 32, 64);
    EXPECT_GT(left.r, 2 * left.b) << name;
    EXPECT_NEAR(right.r, skyRight.r, 0.5) << name;
    EXPECT_NEAR(right.b, skyRight.b, 0.5) << name;
  }
}

TEST(GltfAlphaMask, PrepassAndVisibilityPassAlphaTestToo) {
  // A masked quad in front of an opaque one: where the mask discards, the
  // opaque quad behind must be what the later passes see (its id, its depth).
  GltfWriter w;
  const int t = w.addTexture(64, 64, halves(64, 64, {255, 255, 255, 255}, {255, 255, 255, 0}));
  const int masked = w.addMaterial({{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", t}}},
                                                              {"baseColorFactor", {1.0, 0.1, 0.1, 1.0}}}},
                                    {"alphaMode", "MASK"}});
  const int opaque = w.addMaterial({{"pbrMetallicRoughness", {{"baseColorFactor", {0.1, 0.1, 1.0, 1.0}}}}});
  GltfQuad front = fullView(0.5f, masked);  // at half the distance: half the size fills the view
  for (auto& c : front.corners) c *= glm::vec3(0.5f, 0.5f, 1.0f);
  w.addQuad(front);
  GltfQuad back = fullView(0.0f, opaque);
  for (auto& c : back.corners) c *= glm::vec3(1.2f, 1.2f, 1.0f);  // beyond the view: covers every pixel
  w.addQuad(back);
  const nlohmann::json spec = sceneOf(w, "alpha_mask_over_opaque");
  Rendered reference = render("forward", spec, kExtent);
  ASSERT_TRUE(reference.ok) << reference.error;
  const Rgb refLeft = meanColumns(reference.image, 0, 32), refRight = meanColumns(reference.image, 32, 64);
  EXPECT_GT(refLeft.r, refLeft.b);    // the masked quad's red where it is kept
  EXPECT_GT(refRight.b, refRight.r);  // the opaque quad's blue through the discarded half
  for (const auto& name : kRenderers) {
    Rendered r = render(name, spec, kExtent);
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    // Every pixel is covered by one of the two; each shaded once after the geometry pass.
    if (name != "forward") {
      EXPECT_EQ(passNamed(r, shadingPass(name)).fragmentInvocations, kPixels) << name;
    }
    const Rgb left = meanColumns(r.image, 0, 32), right = meanColumns(r.image, 32, 64);
    EXPECT_GT(left.r, left.b) << name;
    EXPECT_GT(right.b, right.r) << name;
    EXPECT_NEAR(left.r, refLeft.r, 3.0) << name;
    EXPECT_NEAR(right.b, refRight.b, 3.0) << name;
  }
}

TEST(GltfAlphaBlend, TransparentPassBlendsBackToFrontAfterTheOpaquePasses) {
  // An opaque blue quad fills the view at z = 0. Two half-transparent quads
  // cover the left half: red nearer (z = 0.5), green farther (z = 0.25),
  // listed near first. Back to front gives 0.5 red + 0.25 green + 0.25 blue;
  // the file's order would give 0.5 green + 0.25 red.
  GltfWriter w;
  const int blue = w.addMaterial({{"pbrMetallicRoughness", {{"baseColorFactor", {0.05, 0.05, 1.0, 1.0}}}}});
  const int red = w.addMaterial(
      {{"pbrMetallicRoughness", {{"baseColorFactor", {1.0, 0.0, 0.0, 0.5}}}}, {"alphaMode", "BLEND"}});
  const int green = w.addMaterial(
      {{"pbrMetallicRoughness", {{"baseColorFactor", {0.0, 1.0, 0.0, 0.5}}}}, {"alphaMode", "BLEND"}});
  w.addQuad(quadFacingCamera(-3.0f, -3.0f, 0.0f, 3.0f, 0.5f, red));
  w.addQuad(quadFacingCamera(-3.0f, -3.0f, 0.0f, 3.0f, 0.25f, green));
  GltfQuad back = fullView(0.0f, blue);
  for (auto& c : back.corners) c *= glm::vec3(1.2f, 1.2f, 1.0f);
  w.addQuad(back);
  const nlohmann::json spec = sceneOf(w, "alpha_blend");
  for (const auto& name : kRenderers) {
    Rendered r = render(name, spec, kExtent);
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    const PassResult& t = passNamed(r, "transparent");
    ASSERT_EQ(r.frame.passes.back().name, "transparent") << name << ": the last pass, after the sky";
    // Both transparent quads over the left half, neither behind the opaque one.
    EXPECT_EQ(t.fragmentInvocations, 2 * kLeftHalf) << name;
    EXPECT_EQ(counted(t, "final", true), 2 * kLeftHalf) << name;
    EXPECT_EQ(counted(t, "final", false, "derived"), 2 * kLeftHalf) << name << ": blending reads the destination";
    // The opaque passes never see them: one shaded pixel per pixel of the blue quad.
    if (name != "forward") {
      EXPECT_EQ(passNamed(r, shadingPass(name)).fragmentInvocations, kPixels) << name;
    }
    const Rgb left = meanColumns(r.image, 0, 32), right = meanColumns(r.image, 32, 64);
    EXPECT_GT(left.r, 1.3 * left.g) << name << ": red is nearer, so it must weigh twice green";
    EXPECT_GT(left.r, right.r + 10) << name;
    EXPECT_GT(right.b, right.r) << name;
  }
}

TEST(GltfDoubleSided, BackFacesAreCulledPerDrawUnlessDoubleSided) {
  // The same quad wound clockwise as seen from the camera (its back face
  // towards it): single-sided it is culled, double-sided it fills the view.
  // A mirrored node (scale -1 in x) of a front-facing quad stays front-facing.
  for (const char* kind : {"single", "double", "mirrored"}) {
    GltfWriter w;
    const bool doubleSided = std::string(kind) == "double";
    const int m = w.addMaterial({{"pbrMetallicRoughness", {{"baseColorFactor", {1.0, 0.1, 0.1, 1.0}}}},
                                 {"doubleSided", doubleSided}});
    GltfQuad q = fullView(0.0f, m);
    if (std::string(kind) == "mirrored") {
      q.node = {{"scale", {-1.0, 1.0, 1.0}}};
    } else {
      std::swap(q.corners[1], q.corners[3]);  // clockwise from the front: the back face looks at the camera
      std::swap(q.uv[1], q.uv[3]);
    }
    w.addQuad(q);
    // A second, double-sided quad far behind keeps the scene's bounds (and lights) the same size.
    const int behind = w.addMaterial({{"doubleSided", true}});
    w.addQuad(quadFacingCamera(-0.01f, -0.01f, 0.01f, 0.01f, -50.0f, behind));
    const nlohmann::json spec = sceneOf(w, std::string("sided_") + kind);
    const bool visible = std::string(kind) != "single";
    // The far quad covers a few pixels at the centre: derive them from its size.
    for (const auto& name : kRenderers) {
      Rendered r = render(name, spec, kExtent);
      ASSERT_TRUE(r.ok) << name << ": " << r.error;
      const uint64_t shaded = passNamed(r, shadingPass(name)).fragmentInvocations;
      if (visible) {
        EXPECT_EQ(shaded, kPixels) << kind << " " << name;
      } else {
        // Only the far quad: 0.02 m at 51 m is 0.02 / (2 x 51 x tan 30) x 36 = 0.012 rows: no pixel centre.
        EXPECT_EQ(shaded, 0u) << kind << " " << name;
      }
    }
  }
}


// Mean brightness (R + G + B) / 3 of the columns [x0, x1) and rows [y0, y1).
double brightness(const std::vector<uint8_t>& image, uint32_t x0, uint32_t x1, uint32_t y0, uint32_t y1) {
  const Rgb m = meanRect(image, x0, x1, y0, y1);
  return (m.r + m.g + m.b) / 3.0;
}

// Three strips of the view (12 rows each, top to bottom in the image), each
// a quad of the given material and uvs.
void addStrips(GltfWriter& w, const std::array<int, 3>& materials, const std::array<std::array<glm::vec2, 4>, 3>& uvs,
               const std::array<std::optional<std::array<glm::vec2, 4>>, 3>& uv1 = {}) {
  for (int i = 0; i < 3; ++i) {
    const float top = kHalfHeight * (1.0f - 2.0f * float(i) / 3.0f);
    const float bottom = kHalfHeight * (1.0f - 2.0f * float(i + 1) / 3.0f);
    GltfQuad q = quadFacingCamera(-kHalfWidth, bottom, kHalfWidth, top, 0.0f, materials[size_t(i)]);
    q.uv = uvs[size_t(i)];
    q.uv1 = uv1[size_t(i)];
    w.addQuad(q);
  }
}

// uvs with u from 0 at the left edge to `u1` at the right, v from 0 to 1.
std::array<glm::vec2, 4> uSpan(float u0, float u1) {
  return {glm::vec2(u0, 0), glm::vec2(u1, 0), glm::vec2(u1, 1), glm::vec2(u0, 1)};
}

// Whether the middle 8 columns of each quarter of the strip's middle rows are
// bright: closer to `bright` than to `dark`.
std::vector<bool> quarters(const std::vector<uint8_t>& image, int strip, double dark, double bright) {
  std::vector<bool> out;
  const uint32_t y0 = uint32_t(strip) * 12 + 3, y1 = y0 + 6;
  for (uint32_t q = 0; q < 4; ++q) {
    const double b = brightness(image, q * 16 + 4, q * 16 + 12, y0, y1);
    out.push_back(std::abs(b - bright) < std::abs(b - dark));
  }
  return out;
}

const glm::u8vec4 kBlack = {0, 0, 0, 255}, kWhite = {255, 255, 255, 255};

TEST(GltfSamplers, EachTextureWrapsAsItsSamplerSays) {
  // u from 0 to 2 across the view; the texture is black left, white right:
  //   repeat   0-.5 black, .5-1 white, 1-1.5 black, 1.5-2 white: B W B W
  //   clamp    u > 1 reads the right edge (white):               B W W W
  //   mirrored 1-2 reads 1-0:                                     B W W B
  GltfWriter w;
  const auto texels = halves(64, 64, kBlack, kWhite);
  const int repeat = w.addTexture(64, 64, texels, {{"wrapS", 10497}, {"wrapT", 10497}});
  const int clamp = w.addTexture(64, 64, texels, {{"wrapS", 33071}, {"wrapT", 10497}});
  const int mirror = w.addTexture(64, 64, texels, {{"wrapS", 33648}, {"wrapT", 10497}});
  std::array<int, 3> materials;
  for (int i = 0; i < 3; ++i) {
    materials[size_t(i)] = w.addMaterial(
        {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", std::array{repeat, clamp, mirror}[size_t(i)]}}}}},
         {"emissiveFactor", {0.0, 0.0, 0.0}}});
  }
  addStrips(w, materials, {uSpan(0, 2), uSpan(0, 2), uSpan(0, 2)});
  const nlohmann::json spec = sceneOf(w, "samplers");
  const std::vector<std::vector<bool>> want = {{false, true, false, true}, {false, true, true, true},
                                               {false, true, true, false}};
  for (const auto& name : kRenderers) {
    Rendered r = render(name, spec, kExtent);
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    for (int strip = 0; strip < 3; ++strip) {
      // Quarter 0 is black and quarter 1 white in every mode: the references.
      const uint32_t y0 = uint32_t(strip) * 12 + 3;
      const double dark = brightness(r.image, 4, 12, y0, y0 + 6), bright = brightness(r.image, 20, 28, y0, y0 + 6);
      ASSERT_GT(bright, dark + 20) << name << " strip " << strip;
      EXPECT_EQ(quarters(r.image, strip, dark, bright), want[size_t(strip)]) << name << " strip " << strip;
    }
  }
}

TEST(GltfUvSets, MapsSampleTheirUvSetThroughTheirTransform) {
  // TEXCOORD_0 is 0 everywhere (black); TEXCOORD_1 spans 0..1. Top strip:
  // the map samples TEXCOORD_1: dark left, bright right. Middle: the same
  // with KHR_texture_transform offset (0.5, 0): bright left, dark right
  // (u + 0.5 repeats). Bottom: TEXCOORD_0: dark everywhere.
  GltfWriter w;
  w.useExtension("KHR_texture_transform");
  const int t = w.addTexture(64, 64, halves(64, 64, kBlack, kWhite));
  const int uv1 = w.addMaterial({{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", t}, {"texCoord", 1}}}}}});
  nlohmann::json shiftedInfo = {{"index", t}, {"texCoord", 1}};
  shiftedInfo["extensions"]["KHR_texture_transform"]["offset"] = {0.5, 0.0};
  nlohmann::json shiftedMaterial;
  shiftedMaterial["pbrMetallicRoughness"]["baseColorTexture"] = shiftedInfo;
  const int shifted = w.addMaterial(shiftedMaterial);
  const int uv0 = w.addMaterial({{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", t}}}}}});
  const std::array<glm::vec2, 4> zero = {glm::vec2(0), glm::vec2(0), glm::vec2(0), glm::vec2(0)};
  addStrips(w, {uv1, shifted, uv0}, {zero, zero, zero}, {uSpan(0, 1), uSpan(0, 1), uSpan(0, 1)});
  const nlohmann::json spec = sceneOf(w, "uv_sets");
  for (const auto& name : kRenderers) {
    Rendered r = render(name, spec, kExtent);
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    const double leftTop = brightness(r.image, 4, 28, 3, 9), rightTop = brightness(r.image, 36, 60, 3, 9);
    const double leftMid = brightness(r.image, 4, 28, 15, 21), rightMid = brightness(r.image, 36, 60, 15, 21);
    const double leftLow = brightness(r.image, 4, 28, 27, 33), rightLow = brightness(r.image, 36, 60, 27, 33);
    EXPECT_GT(rightTop, leftTop + 20) << name;
    EXPECT_GT(leftMid, rightMid + 20) << name;
    EXPECT_NEAR(leftLow, rightLow, 4) << name;
    EXPECT_LT(rightLow, rightTop - 20) << name;
  }
}

TEST(GltfVertexColors, ColourMultipliesTheBaseColourAndIsCounted) {
  // White material; COLOR_0 red at the left corners, blue at the right.
  GltfWriter w;
  const int m = w.addMaterial({{"pbrMetallicRoughness", {{"baseColorFactor", {1.0, 1.0, 1.0, 1.0}}}}});
  GltfQuad q = fullView(0.0f, m);
  q.color = std::array<glm::vec4, 4>{glm::vec4(1, 0, 0, 1), glm::vec4(0, 0, 1, 1), glm::vec4(0, 0, 1, 1),
                                     glm::vec4(1, 0, 0, 1)};
  w.addQuad(q);
  const nlohmann::json spec = sceneOf(w, "vertex_colors");
  for (const auto& name : kRenderers) {
    Rendered r = render(name, spec, kExtent);
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    const Rgb left = meanColumns(r.image, 0, 16), right = meanColumns(r.image, 48, 64);
    EXPECT_GT(left.r, 2 * left.b) << name;
    EXPECT_GT(right.b, 2 * right.r) << name;
    EXPECT_LT(left.g, left.r / 4) << name;
    // The colours are read where the renderer reads vertices: the vertex
    // stage (4 vertices) or, in the visibility buffers' shading, 3 vertices per pixel.
    uint64_t reads = 0;
    for (const auto& p : r.frame.passes) reads += counted(p, "vertex_attributes", false);
    if (name == "visbuffer" || name == "visbuffer-lean") {
      EXPECT_GE(counted(passNamed(r, "shading"), "vertex_attributes", false), 3 * kPixels) << name;
    } else {
      EXPECT_GT(reads, 0u) << name;
      EXPECT_LE(reads, 4u * 4u) << name << ": one read per vertex and pass";
    }
  }
}

TEST(GltfEmissive, EmissionIsAddedInEveryRenderer) {
  // A black material that emits (0, 0.8, 0): green everywhere. A second,
  // lower strip emits red through an emissive map white on the left only.
  GltfWriter w;
  const int t = w.addTexture(64, 64, halves(64, 64, kWhite, kBlack));
  const int factor = w.addMaterial(
      {{"pbrMetallicRoughness", {{"baseColorFactor", {0.0, 0.0, 0.0, 1.0}}}}, {"emissiveFactor", {0.0, 0.8, 0.0}}});
  const int mapped = w.addMaterial({{"pbrMetallicRoughness", {{"baseColorFactor", {0.0, 0.0, 0.0, 1.0}}}},
                                    {"emissiveFactor", {1.0, 0.0, 0.0}},
                                    {"emissiveTexture", {{"index", t}}}});
  addStrips(w, {factor, factor, mapped}, {uSpan(0, 1), uSpan(0, 1), uSpan(0, 1)});
  const nlohmann::json spec = sceneOf(w, "emissive");
  for (const auto& name : kRenderers) {
    Rendered r = render(name, spec, kExtent);
    ASSERT_TRUE(r.ok) << name << ": " << r.error;
    const Rgb top = meanColumns(r.image, 0, 64);  // all rows: green dominates the two upper strips
    EXPECT_GT(top.g, 2 * top.r) << name;
    const Rgb low = meanRect(r.image, 4, 28, 27, 33), lowRight = meanRect(r.image, 36, 60, 27, 33);
    EXPECT_GT(low.r, lowRight.r + 40) << name << ": the emissive map's white half";
    if (name == "deferred") {
      // The emission travels in its own G-buffer target, written and read once per covered pixel.
      EXPECT_EQ(counted(passNamed(r, "gbuffer"), "gbuffer.emissive", true), kPixels);
      EXPECT_EQ(counted(passNamed(r, "lighting"), "gbuffer.emissive", false), kPixels);
    }
  }
}

// The visibility buffers' per-material split of their material-map reads,
// derived by hand: a left half of material "left" (a base colour texture
// and its own normal texture), a right half of "right" (its own base colour
// and normal textures, and left's base colour texture as its emissive map).
// Each covered pixel reads each of its material's maps once, so "left" reads
// its own texture once per left pixel, "right" its two own textures once per
// right pixel each, and the shared texture's entry, "left + right", once per
// pixel of the view. Every covered pixel is shaded once (kLeftHalf each
// side: the seam lies on a pixel edge). Only the descriptor-indexing path
// counts per texture; on texture arrays (lavapipe) materials are layers of
// one array and the split is not counted (a device property: skipped).
TEST(GltfMaterialSplit, VisibilityShadingReadsSplitPerMaterialAsDerivedByHand) {
  GltfWriter w;
  const int leftBase = w.addTexture(8, 8, halves(8, 8, kWhite, kWhite));
  const int rightBase = w.addTexture(8, 8, halves(8, 8, kBlack, kWhite));
  const int rightNormal = w.addTexture(8, 8, halves(8, 8, glm::u8vec4(128, 128, 255, 255), glm::u8vec4(128, 128, 255, 255)));
  const int leftNormal = w.addTexture(4, 4, halves(4, 4, glm::u8vec4(128, 128, 255, 255), glm::u8vec4(128, 128, 255, 255)));
  const int left = w.addMaterial({{"name", "left"},
                                  {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", leftBase}}}}},
                                  {"normalTexture", {{"index", leftNormal}}}});
  const int right = w.addMaterial({{"name", "right"},
                                   {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", rightBase}}}}},
                                   {"normalTexture", {{"index", rightNormal}}},
                                   {"emissiveFactor", {0.1, 0.1, 0.1}},
                                   {"emissiveTexture", {{"index", leftBase}}}});
  w.addQuad(quadFacingCamera(-kHalfWidth, -kHalfHeight, 0.0f, kHalfHeight, 0.0f, left));
  w.addQuad(quadFacingCamera(0.0f, -kHalfHeight, kHalfWidth, kHalfHeight, 0.0f, right));
  const nlohmann::json spec = sceneOf(w, "material_split");
  for (const char* name : {"visbuffer", "visbuffer-lean"}) {
    for (bool compute : {false, true}) {
      SCOPED_TRACE(std::string(name) + (compute ? " compute" : " fragment"));
      Rendered r = render(name, spec, kExtent, [&](RendererOptions& o) {
        o.draws = true;
        o.computeShading = compute;
      });
      ASSERT_TRUE(r.ok) << r.error;
      if (r.notes.value("material_maps", "") != "descriptor_indexing") {
        GTEST_SKIP() << "the device has no descriptor indexing: materials are layers of texture arrays";
      }
      std::map<std::string, uint64_t> reads;
      std::string entries;
      for (const MaterialCount& m : passNamed(r, "shading").materials) {
        reads[m.material] += m.count;
        entries += " '" + m.material + "': " + std::to_string(m.count);
      }
      SCOPED_TRACE("entries:" + entries);
      EXPECT_EQ(reads["left"], kLeftHalf);
      EXPECT_EQ(reads["right"], 2 * kLeftHalf);
      EXPECT_EQ(reads["left + right"], kPixels);
      // The visibility pass's own per-draw counts, a second mechanism: each
      // draw writes one visibility value per pixel it covers.
      const PassResult& visibility = passNamed(r, "visibility");
      ASSERT_EQ(visibility.draws.size(), 2u);
      EXPECT_EQ(visibility.draws[0].bytesWritten, visibility.draws[1].bytesWritten);
    }
  }
}

}  // namespace
}  // namespace tally::renderers
