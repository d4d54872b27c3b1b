// Packed tangent frames (docs/techniques.md, "Packed tangent frames"): the
// 24-bit quaternion's round trip against its derived bound, the GLSL decoder
// against the C++ encoder (a compute kernel), the vertex bytes each variant
// reads (derived from the two strides and the counted vertex invocations), the
// quaternion variant's image against the float one for every renderer, and
// the option table.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/image.hpp"
#include "gpu/pipelines.hpp"
#include "gpu/resources.hpp"
#include "gpu/shaders.hpp"
#include "render_fixture.hpp"
#include "renderers/options.hpp"
#include "renderers/techniques/tbn.hpp"
#include "scenes/spec.hpp"
#include "shared.h"

namespace tally::renderers {
using namespace fixture;
namespace {

constexpr double kPi = 3.14159265358979323846;

struct Frame {
  glm::vec3 normal;
  glm::vec4 tangent;  // w: bitangent sign
};

glm::vec3 randomUnit(std::mt19937& rng) {
  std::normal_distribution<float> g;
  for (;;) {
    glm::vec3 v(g(rng), g(rng), g(rng));
    if (glm::length(v) > 1e-3f) return glm::normalize(v);
  }
}

// Dense random frames, both handednesses, half of them with a tangent that is
// not orthogonal to the normal (as a loader might leave it), plus the frames
// where the quaternion is special: the 24 axis-aligned rotations (components
// 0 and +-1, +-1/sqrt 2, +-1/2) and ties between components.
std::vector<Frame> testFrames(size_t randomCount) {
  std::mt19937 rng(1234);
  std::vector<Frame> frames;
  for (size_t i = 0; i < randomCount; ++i) {
    glm::vec3 n = randomUnit(rng);
    glm::vec3 t = randomUnit(rng);
    if (i % 2 == 0) t = glm::normalize(t - n * glm::dot(n, t));
    frames.push_back({n, glm::vec4(t, (i / 2) % 2 == 0 ? 1.0f : -1.0f)});
  }
  const glm::vec3 axes[] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const auto& n : axes) {
    for (const auto& t : axes) {
      if (std::abs(glm::dot(n, t)) > 0.5f) continue;
      for (float w : {1.0f, -1.0f}) frames.push_back({n, glm::vec4(t, w)});
    }
  }
  // q = (1/2, 1/2, 1/2, 1/2) and its neighbours: the bound's worst corner.
  for (float w : {1.0f, -1.0f}) {
    frames.push_back({glm::vec3(0, 1, 0), glm::vec4(0, 0, 1, w)});
    frames.push_back({glm::normalize(glm::vec3(0.01f, 1, 0)), glm::vec4(0, 0, 1, w)});
  }
  return frames;
}

void orthonormal(const Frame& f, glm::vec3& n, glm::vec3& t) {
  n = glm::normalize(f.normal);
  t = glm::normalize(glm::vec3(f.tangent) - n * glm::dot(n, glm::vec3(f.tangent)));
}

// ---------------------------------------------------------------- encoding

TEST(TbnEncoding, TheBoundIsTheDerivedOne) {
  // Half step of 7 bits over [-1/sqrt 2, 1/sqrt 2]; first-order S^3 error
  // sqrt 12 half steps at q = (1/2, 1/2, 1/2, 1/2); twice that for a vector.
  const double half = 1.0 / (127.0 * std::sqrt(2.0));
  EXPECT_NEAR(kTbnHalfStep, half, 1e-15);
  EXPECT_NEAR(kTbnFirstOrderBoundDeg, 2.0 * std::sqrt(12.0) * half * 180.0 / kPi, 1e-6);
  EXPECT_EQ(kTbnBits, 2 + 1 + 3 * kTbnComponentBits);
  EXPECT_EQ(sizeof(PackedVertex), 24u);
  EXPECT_EQ(sizeof(shaders::Vertex), 48u);
}

TEST(TbnEncoding, RoundTripWithinTheBoundAndHandednessKept) {
  const auto frames = testFrames(400000);
  double nMax = 0, tMax = 0, nSum = 0;
  for (const Frame& f : frames) {
    const uint32_t bits = encodeTangentFrame(f.normal, f.tangent);
    ASSERT_EQ(bits >> kTbnBits, 0u) << "24 bits only";
    const DecodedFrame d = decodeTangentFrame(bits);
    glm::vec3 n, t;
    orthonormal(f, n, t);
    const double ne = angleDeg(n, d.normal), te = angleDeg(t, glm::vec3(d.tangent));
    ASSERT_LE(ne, kTbnErrorBoundDeg) << "normal " << f.normal.x << "," << f.normal.y << "," << f.normal.z;
    ASSERT_LE(te, kTbnErrorBoundDeg);
    ASSERT_EQ(d.tangent.w, f.tangent.w < 0 ? -1.0f : 1.0f) << "handedness";
    // The bitangent the shaders build is the frame's: cross(n, t) * sign.
    const glm::vec3 b = glm::cross(n, t) * f.tangent.w;
    const glm::vec3 db = glm::cross(d.normal, glm::vec3(d.tangent)) * d.tangent.w;
    ASSERT_LE(angleDeg(b, db), kTbnErrorBoundDeg);
    ASSERT_NEAR(glm::length(d.normal), 1.0f, 1e-5f);
    ASSERT_NEAR(glm::dot(d.normal, glm::vec3(d.tangent)), 0.0f, 1e-5f);
    nMax = std::max(nMax, ne);
    tMax = std::max(tMax, te);
    nSum += ne;
  }
  std::printf("%zu frames: normal error max %.4f mean %.4f deg, tangent max %.4f deg (bound %.4f)\n",
              frames.size(), nMax, nSum / double(frames.size()), tMax, kTbnErrorBoundDeg);
  // 7-bit components: the error is a quantisation's, not zero.
  EXPECT_GT(nMax, 0.1);
}

// The renderers' GLSL decoder (shaders/tbn.h, in a compute kernel) against
// the C++ decoder twin and the source frames.
TEST(TbnEncoding, GlslDecoderAgreesWithTheCppEncoder) {
  gpu::Context* ctx = context();
  ASSERT_NE(ctx, nullptr);
  const auto frames = testFrames(65536);
  std::vector<uint32_t> words;
  for (const Frame& f : frames) words.push_back(encodeTangentFrame(f.normal, f.tangent));
  const uint32_t count = uint32_t(words.size());

  auto source = gpu::loadShaderSource(*ctx, shaderDirectory().value(), "tbn_decode.comp.glsl");
  ASSERT_TRUE(source.ok()) << source.error();
  auto compiled = gpu::compileShader(*source);
  ASSERT_TRUE(compiled.ok()) << compiled.error();
  VkShaderModule module = gpu::createShaderModule(*ctx, compiled->words);
  VkDescriptorSetLayoutBinding bindings[2] = {};
  for (uint32_t i = 0; i < 2; ++i) {
    bindings[i].binding = i;
    bindings[i].descriptorType = VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    bindings[i].descriptorCount = 1;
    bindings[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  VkDescriptorSetLayout setLayout = gpu::createDescriptorSetLayout(*ctx, bindings);
  VkPipelineLayout layout = gpu::createPipelineLayout(*ctx, {&setLayout, 1});
  VkPipeline pipeline = gpu::createComputePipeline(*ctx, module, layout);
  VkDescriptorPoolSize size = {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, 2};
  VkDescriptorPool pool = gpu::createDescriptorPool(*ctx, 1, {&size, 1});
  VkDescriptorSet set = gpu::allocateDescriptorSet(*ctx, pool, setLayout);
  gpu::Buffer in = gpu::createBuffer(*ctx, count * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, gpu::MemoryUse::Upload);
  gpu::Buffer out = gpu::createBuffer(*ctx, uint64_t(count) * 32,
                                      VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                      gpu::MemoryUse::Readback);
  gpu::uploadBuffer(*ctx, in, {reinterpret_cast<const uint8_t*>(words.data()), words.size() * 4});
  gpu::DescriptorWrite writes[2];
  writes[0].binding = 0;
  writes[0].buffer = {in.buffer, 0, VK_WHOLE_SIZE};
  writes[1].binding = 1;
  writes[1].buffer = {out.buffer, 0, VK_WHOLE_SIZE};
  gpu::updateDescriptorSet(*ctx, set, writes);
  gpu::submitAndWait(*ctx, [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &set, 0, nullptr);
    vkCmdDispatch(cmd, (count + 63) / 64, 1, 1);
  });
  const std::vector<uint8_t> raw = gpu::readBuffer(*ctx, out);
  std::vector<glm::vec4> decoded(size_t(count) * 2);
  std::memcpy(decoded.data(), raw.data(), decoded.size() * sizeof(glm::vec4));
  vkDestroyPipeline(ctx->device, pipeline, nullptr);
  vkDestroyPipelineLayout(ctx->device, layout, nullptr);
  vkDestroyDescriptorPool(ctx->device, pool, nullptr);
  vkDestroyDescriptorSetLayout(ctx->device, setLayout, nullptr);
  gpu::destroyShaderModule(*ctx, module);
  gpu::destroyBuffer(*ctx, in);
  gpu::destroyBuffer(*ctx, out);

  float maxDiff = 0;
  double maxError = 0;
  for (uint32_t i = 0; i < count; ++i) {
    const DecodedFrame cpu = decodeTangentFrame(words[i]);
    const glm::vec3 gn(decoded[2 * i]);
    const glm::vec4 gt = decoded[2 * i + 1];
    for (int c = 0; c < 3; ++c) {
      maxDiff = std::max({maxDiff, std::abs(gn[c] - cpu.normal[c]), std::abs(gt[c] - cpu.tangent[c])});
    }
    ASSERT_EQ(gt.w, frames[i].tangent.w < 0 ? -1.0f : 1.0f) << "GLSL handedness, frame " << i;
    glm::vec3 n, t;
    orthonormal(frames[i], n, t);
    maxError = std::max({maxError, angleDeg(n, gn), angleDeg(t, glm::vec3(gt))});
  }
  std::printf("GLSL vs C++ decode: max component difference %.3g; GLSL vs source frame max %.4f deg\n",
              double(maxDiff), maxError);
  // float arithmetic in another order (and the driver's sqrt): a few ulps.
  EXPECT_LE(maxDiff, 1e-5f);
  EXPECT_LE(maxError, kTbnErrorBoundDeg);
}

// ---------------------------------------------------------------- renderers

std::function<void(RendererOptions&)> withFrame(TangentFrameEncoding e) {
  return [=](RendererOptions& o) { o.tangentFrame = e; };
}

const ResourceInfo* resourceNamed(const Rendered& r, const std::string& name) {
  for (const auto& info : r.resources) {
    if (info.name == name) return &info;
  }
  return nullptr;
}

// The "vertices" reads of a pass's vertex attributes and shader loads.
uint64_t vertexReads(const PassResult& p) { return counted(p, "vertices", false); }

// Passes with vertex input: every declared attribute is counted once per
// vertex invocation, its shader type's bytes. mesh.vert.h declares 4
// attributes (float: vec3 + vec3 + vec4 + vec2 = 48 bytes, the stride) or 3
// (quaternion: vec3 + uint + vec2 = 24, the packed stride). So the invocations
// are reads / attributes, equal in both variants (same indices, same draws),
// and the bytes invocations x stride: their ratio stride_q / stride_f.
TEST(TbnBandwidth, VertexInputBytesFollowTheStrides) {
  const VkExtent2D extent = {64, 36};
  struct Case {
    const char* renderer;
    const char* pass;
  };
  for (const Case& c : {Case{"forward", "forward"}, Case{"deferred", "gbuffer"}}) {
    Rendered f = render(c.renderer, "atrium", extent, withFrame(TangentFrameEncoding::Float));
    Rendered q = render(c.renderer, "atrium", extent, withFrame(TangentFrameEncoding::Quaternion));
    ASSERT_TRUE(f.ok && q.ok) << f.error << q.error;
    const ResourceInfo* vf = resourceNamed(f, "vertices");
    const ResourceInfo* vq = resourceNamed(q, "vertices");
    ASSERT_TRUE(vf && vq);
    ASSERT_EQ(vf->elementBytes, sizeof(shaders::Vertex));
    ASSERT_EQ(vq->elementBytes, sizeof(PackedVertex));
    const PassResult& pf = passNamed(f, c.pass);
    const PassResult& pq = passNamed(q, c.pass);
    const uint64_t readsF = vertexReads(pf), readsQ = vertexReads(pq);
    ASSERT_GT(readsF, 0u);
    ASSERT_EQ(readsF % 4, 0u);
    ASSERT_EQ(readsQ % 3, 0u);
    const uint64_t invocations = readsF / 4;
    EXPECT_EQ(readsQ / 3, invocations) << c.renderer << ": the same vertex invocations";
    EXPECT_EQ(bytes(pf, "vertices", false), invocations * vf->elementBytes) << c.renderer;
    EXPECT_EQ(bytes(pq, "vertices", false), invocations * vq->elementBytes) << c.renderer;
    EXPECT_EQ(bytes(pq, "vertices", false) * vf->elementBytes, bytes(pf, "vertices", false) * vq->elementBytes);
    // Index fetches are the indices drawn, the same in both.
    EXPECT_EQ(bytes(pf, "indices", false, "derived"), bytes(pq, "indices", false, "derived"));
    // The packed buffer's real allocation: at least stride x vertices, below the float buffer's.
    const uint64_t vertices = q.extras["tangent_frame"]["vertex_count"].get<uint64_t>();
    EXPECT_GE(vq->allocationBytes, vertices * sizeof(PackedVertex));
    EXPECT_GE(vf->allocationBytes, vertices * sizeof(shaders::Vertex));
    EXPECT_LT(vq->allocationBytes, vf->allocationBytes);
    std::printf("%s %s: %llu vertex invocations, vertex bytes float %llu quaternion %llu\n", c.renderer, c.pass,
                (unsigned long long)invocations, (unsigned long long)bytes(pf, "vertices", false),
                (unsigned long long)bytes(pq, "vertices", false));
  }
  // The depth pre-pass reads the position alone: 12 bytes per invocation in both.
  Rendered f = render("forward-zprepass", "atrium", extent, withFrame(TangentFrameEncoding::Float));
  Rendered q = render("forward-zprepass", "atrium", extent, withFrame(TangentFrameEncoding::Quaternion));
  ASSERT_TRUE(f.ok && q.ok);
  const PassResult& zf = passNamed(f, "zprepass");
  const PassResult& zq = passNamed(q, "zprepass");
  EXPECT_EQ(bytes(zf, "vertices", false), vertexReads(zf) * 12);
  EXPECT_EQ(bytes(zq, "vertices", false), bytes(zf, "vertices", false));
}

// The visibility buffers' shading passes load whole vertices (3 per shaded
// pixel): each load is one vertex of the bound layout, 48 or 24 bytes, and the
// loads are the same in both (the visibility ids depend on positions only).
TEST(TbnBandwidth, ShadingPassFetchesFollowThePackedLayout) {
  const VkExtent2D extent = {64, 36};
  for (const char* name : {"visbuffer", "visbuffer-lean"}) {
    Rendered f = render(name, "atrium", extent, withFrame(TangentFrameEncoding::Float));
    Rendered q = render(name, "atrium", extent, withFrame(TangentFrameEncoding::Quaternion));
    ASSERT_TRUE(f.ok && q.ok) << f.error << q.error;
    const PassResult& sf = passNamed(f, "shading");
    const PassResult& sq = passNamed(q, "shading");
    const uint64_t loads = vertexReads(sf);
    ASSERT_GT(loads, 0u);
    EXPECT_EQ(loads % 3, 0u);
    EXPECT_EQ(loads / 3, sf.fragmentInvocations) << name << ": three vertices per shaded pixel";
    EXPECT_EQ(vertexReads(sq), loads) << name;
    EXPECT_EQ(bytes(sf, "vertices", false), loads * sizeof(shaders::Vertex)) << name;
    EXPECT_EQ(bytes(sq, "vertices", false), loads * sizeof(PackedVertex)) << name;
    std::printf("%s shading: %llu vertex loads, bytes float %llu quaternion %llu\n", name,
                (unsigned long long)loads, (unsigned long long)bytes(sf, "vertices", false),
                (unsigned long long)bytes(sq, "vertices", false));
  }
}

// The quaternion variant against the float one. The frames differ by at most
// kTbnErrorBoundDeg (2.2 degrees). Diffuse N.L moves by at most sin 2.2 deg
// ~ 0.04 of a light's contribution; a specular lobe of exponent up to 2048
// (shared.h kMaxShininess) is ~1.8 degrees wide, so a highlight pixel can move
// by any amount and no per-pixel maximum follows. What is asserted is the
// aggregate: PSNR above 40 dB (a mean squared error of ~6.5 8-bit steps^2)
// and a mean error below one 8-bit step.
TEST(TbnImages, QuaternionAgainstFloatEveryRenderer) {
  const VkExtent2D extent = {96, 54};
  constexpr double kMinPsnr = 40.0;
  constexpr double kMaxMeanAbs = 1.0;
  for (const auto& name : rendererNames()) {
    Rendered f = render(name, "atrium", extent, withFrame(TangentFrameEncoding::Float));
    Rendered q = render(name, "atrium", extent, withFrame(TangentFrameEncoding::Quaternion));
    ASSERT_TRUE(f.ok && q.ok) << name << ": " << f.error << q.error;
    auto e = analysis::compareImages(f.image, q.image, extent.width, extent.height);
    ASSERT_TRUE(e.ok());
    std::printf("%-16s quaternion vs float: PSNR %.1f dB, max %d, mean %.4f\n", name.c_str(), e->psnr, e->maxAbs,
                e->meanAbs);
    EXPECT_GT(e->psnr, kMinPsnr) << name;
    EXPECT_LT(e->meanAbs, kMaxMeanAbs) << name;
    EXPECT_GT(e->meanAbs, 0.0) << name << ": the packed frames change the image";
    // The variant is the packed one, and its extras say so.
    const auto& tf = q.extras["tangent_frame"];
    EXPECT_EQ(tf["encoding"], "quaternion") << name;
    EXPECT_EQ(tf["vertex_stride_bytes"].get<uint32_t>(), resourceNamed(q, "vertices")->elementBytes);
    EXPECT_EQ(tf["tbn_bytes"].get<uint32_t>(), 3u);
    EXPECT_LE(tf["normal_error_deg"]["max"].get<double>(), kTbnErrorBoundDeg);
    EXPECT_LE(tf["tangent_error_deg"]["max"].get<double>(), kTbnErrorBoundDeg);
    EXPECT_LE(tf["normal_error_deg"]["mean"].get<double>(), tf["normal_error_deg"]["max"].get<double>());
    EXPECT_EQ(tf["handedness_flips"].get<uint64_t>(), 0u);
    EXPECT_FALSE(f.extras.contains("tangent_frame")) << "the float variant is the renderer as it was";
  }
}

// The errors over every vertex of a scene (the extras' figures, on the CPU):
// within the bound; printed for the atrium and, where present, Sponza.
TEST(TbnEncoding, SceneVertexErrorsWithinTheBound) {
  std::vector<nlohmann::json> specs = {"atrium"};
  const char* env = std::getenv("TALLY_SPONZA_GLTF");
  const std::string sponza = env != nullptr ? env : TALLY_SPONZA_GLTF;
  if (FILE* f = std::fopen(sponza.c_str(), "rb")) {
    std::fclose(f);
    specs.push_back({{"gltf", sponza}});
  }
  for (const auto& spec : specs) {
    auto scene = scenes::makeScene(spec);
    ASSERT_TRUE(scene.ok()) << scene.error();
    std::vector<glm::vec3> normals;
    std::vector<glm::vec4> tangents;
    for (const auto& mesh : scene->meshes) {
      for (const auto& v : mesh.vertices) {
        normals.push_back(v.normal);
        tangents.push_back(v.tangent);
      }
    }
    const auto e = tangentFrameErrors(normals, tangents);
    std::printf("%s: %zu vertices, %s\n", spec.dump().c_str(), normals.size(), e.dump().c_str());
    EXPECT_LE(e["normal_error_deg"]["max"].get<double>(), kTbnErrorBoundDeg);
    EXPECT_LE(e["tangent_error_deg"]["max"].get<double>(), kTbnErrorBoundDeg);
    EXPECT_EQ(e["handedness_flips"].get<uint64_t>(), 0u);
  }
}

// ---------------------------------------------------------------- options

TEST(TbnOptions, TableTakesFloatAndQuaternionForEveryRenderer) {
  for (const auto& name : rendererNames()) {
    auto own = optionsOf(name);
    auto it = std::find_if(own.begin(), own.end(), [](const OptionDef* d) { return d->name == "tangent_frame"; });
    ASSERT_NE(it, own.end()) << name;
    EXPECT_EQ((*it)->defaultValue(), "float");
    EXPECT_FALSE((*it)->parameter);
    auto q = canonicalOptions(name, {{"tangent_frame", "quaternion"}});
    ASSERT_TRUE(q.ok()) << q.error();
    EXPECT_EQ(*q, nlohmann::json({{"tangent_frame", "quaternion"}}));
    EXPECT_EQ(variantLabel(name, *q), name + " tangent_frame=quaternion");
    auto f = canonicalOptions(name, {{"tangent_frame", "float"}});
    ASSERT_TRUE(f.ok());
    EXPECT_EQ(*f, nlohmann::json::object()) << "the default is dropped";
    RendererOptions o;
    applyOptions(*q, o);
    EXPECT_EQ(o.tangentFrame, TangentFrameEncoding::Quaternion);
  }
  auto bad = canonicalOptions("forward", {{"tangent_frame", "half"}});
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().find("tangent_frame"), std::string::npos) << bad.error();
  EXPECT_NE(bad.error().find("float, quaternion"), std::string::npos) << bad.error();
  EXPECT_FALSE(canonicalOptions("deferred", {{"tangent_frame", true}}).ok());
  EXPECT_EQ(parseTangentFrameEncoding("quaternion"), TangentFrameEncoding::Quaternion);
  EXPECT_FALSE(parseTangentFrameEncoding("Quaternion").has_value());
  bool listed = false;
  for (const auto& d : optionDefsJson()) {
    if (d["name"] == "tangent_frame") listed = d["values"] == nlohmann::json({"float", "quaternion"});
  }
  EXPECT_TRUE(listed);
}

}  // namespace
}  // namespace tally::renderers
