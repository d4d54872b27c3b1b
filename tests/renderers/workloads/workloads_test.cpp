// The compute workloads (docs/techniques.md, "Volume fog", "Ray tracer"):
// option-table and spec checks, and on the test device (lavapipe in CI) the
// counted reads against a CPU replica of each shader's loop structure (the
// same formulas in C++, renderers/workloads/workloads.hpp), and the fog's images across
// octave modes against the fixed-maximum reference.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/image.hpp"
#include "capture/spec.hpp"
#include "render_fixture.hpp"
#include "renderers/options.hpp"
#include "renderers/projection.hpp"
#include "renderers/workloads/workloads.hpp"

namespace tally::renderers {
using namespace fixture;
namespace {

constexpr VkExtent2D kExtent = {64, 36};

struct WorkloadRun {
  bool ok = false;
  FrameResult frame;
  std::vector<uint8_t> image;
  nlohmann::json extras;
  std::vector<std::string> passNames;
};

// The atrium's bounding box, with the camera at its centre looking along -z
// and a little down: every primary ray starts inside the fog box.
scenes::Camera insideCamera(const scenes::Bounds& b) {
  scenes::Camera c;
  c.eye = (b.min + b.max) * 0.5f;
  c.target = c.eye + glm::vec3(0.3f, -0.2f, -1.0f);
  c.fovDeg = 60.0f;
  return c;
}

// A camera outside the box, high above a corner, looking at the centre.
scenes::Camera outsideCamera(const scenes::Bounds& b) {
  scenes::Camera c;
  c.eye = b.max + (b.max - b.min) * 0.3f;
  c.target = (b.min + b.max) * 0.5f;
  c.fovDeg = 50.0f;
  return c;
}

WorkloadRun runWorkload(const std::string& name, const scenes::Camera& camera, const std::function<void(RendererOptions&)>& adjust) {
  WorkloadRun out;
  gpu::Context* ctx = context();
  if (ctx == nullptr) return out;
  TestScene& s = testScene("atrium");
  auto made = makeRenderer(name);
  EXPECT_TRUE(made.ok());
  if (!made) return out;
  RendererOptions o;
  o.extent = kExtent;
  o.lights = kTestLights;
  if (adjust) adjust(o);
  auto ok = (*made)->setup(*ctx, *s.gpu, o);
  EXPECT_TRUE(ok.ok()) << (ok ? "" : ok.error());
  if (!ok) return out;
  out.frame = (*made)->renderFrame(camera);
  out.image = (*made)->finalImage();
  out.extras = (*made)->frameExtras();
  out.passNames = (*made)->passNames();
  EXPECT_TRUE((*made)->depthImage().empty());
  (*made)->destroy();
  out.ok = true;
  return out;
}

uint64_t readsOf(const WorkloadRun& r, const std::string& pass, const std::string& resource) {
  for (const auto& p : r.frame.passes) {
    if (p.name != pass) continue;
    uint64_t n = 0;
    for (const auto& a : p.accesses) {
      if (!a.write && a.source == "counter" && a.resource == resource) n += a.count;
    }
    return n;
  }
  return 0;
}

uint64_t writesOf(const WorkloadRun& r, const std::string& pass, const std::string& resource) {
  for (const auto& p : r.frame.passes) {
    if (p.name != pass) continue;
    for (const auto& a : p.accesses) {
      if (a.write && a.resource == resource) return a.count;
    }
  }
  return 0;
}

// ------------------------------------------------------------ the CPU replica

struct Ray {
  glm::vec3 o, d;
};

Ray pixelRay(const scenes::Camera& camera, uint32_t x, uint32_t y) {
  const scenes::Bounds& b = testScene("atrium").gpu->bounds();
  shaders::Camera c = cameraUniform(camera, kExtent, depthRangeFor(b, camera));
  return {camera.eye, workloadRayDirection(c.view, c.proj, glm::vec2(kExtent.width, kExtent.height), x, y)};
}

// Trilinear, REPEAT, of the R8 density texture (texel centres at (i + 0.5) / n).
float sampleDensity(const std::vector<uint8_t>& texels, glm::vec3 uvw) {
  const int n = int(kFogTextureSize);
  glm::vec3 p = uvw * float(n) - 0.5f;
  glm::vec3 f = glm::floor(p);
  glm::vec3 w = p - f;
  auto at = [&](int x, int y, int z) {
    x = ((x % n) + n) % n;
    y = ((y % n) + n) % n;
    z = ((z % n) + n) % n;
    return float(texels[(size_t(z) * n + y) * n + x]) / 255.0f;
  };
  int x = int(f.x), y = int(f.y), z = int(f.z);
  float v = 0;
  for (int k = 0; k < 8; ++k) {
    int dx = k & 1, dy = (k >> 1) & 1, dz = (k >> 2) & 1;
    float weight = (dx ? w.x : 1 - w.x) * (dy ? w.y : 1 - w.y) * (dz ? w.z : 1 - w.z);
    v += weight * at(x + dx, y + dy, z + dz);
  }
  return v;
}

struct FogPrediction {
  uint64_t reads = 0;    // texture() calls on "fog_density"
  uint64_t samples = 0;  // ray-march samples
  uint64_t rays = 0;     // rays that cross the box
};

// volume_fog.comp.glsl's loop structure with the same formulas; the density
// (and so early termination) only where `terminate`.
FogPrediction predictFog(const scenes::Camera& camera, const WorkloadOptions& o, bool terminate) {
  const scenes::Bounds& b = testScene("atrium").gpu->bounds();
  const FogVolume v = fogVolumeFor(b, o.fogDensity);
  static const std::vector<uint8_t> texels = fogDensityTexels();
  const float total = 2.0f * (1.0f - std::exp2(-float(o.fogMaxOctaves)));
  FogPrediction out;
  for (uint32_t y = 0; y < kExtent.height; ++y) {
    for (uint32_t x = 0; x < kExtent.width; ++x) {
      Ray r = pixelRay(camera, x, y);
      glm::vec3 inv = 1.0f / r.d;
      glm::vec3 ta = (v.min - r.o) * inv, tb = (v.max - r.o) * inv;
      glm::vec3 tn = glm::min(ta, tb), tf = glm::max(ta, tb);
      float tEnter = std::max(std::max(std::max(tn.x, tn.y), tn.z), 0.0f);
      float tExit = std::min(std::min(tf.x, tf.y), tf.z);
      if (!(tExit > tEnter)) continue;
      ++out.rays;
      float dt = (tExit - tEnter) / float(o.fogSteps);
      float transmittance = 1.0f;
      for (uint32_t i = 0; i < o.fogSteps; ++i) {
        float t = tEnter + (float(i) + 0.5f) * dt;
        uint32_t n = o.fogOctaves == FogOctaves::Dynamic ? fogDynamicOctaves(t, v.t0, o.fogMaxOctaves)
                                                         : o.fogMaxOctaves;
        out.reads += n;
        ++out.samples;
        if (!terminate) continue;
        glm::vec3 uvw = (r.o + r.d * t - v.min) / v.tileSize;
        float sum = 0, amplitude = 1, frequency = 1;
        for (uint32_t k = 0; k < n; ++k) {
          sum += amplitude * sampleDensity(texels, uvw * frequency);
          amplitude *= 0.5f;
          frequency *= 2.0f;
        }
        sum += 0.5f * (total - 2.0f * (1.0f - std::exp2(-float(n))));
        float alpha = 1.0f - std::exp(-v.sigmaScale * (sum / total) * dt);
        transmittance *= 1.0f - alpha;
        if (1.0f - transmittance >= kFogTerminationOpacity) break;
      }
    }
  }
  return out;
}

struct RayCounts {
  uint64_t primary = 0, shadow = 0, reflection = 0;
  uint64_t total() const { return primary + shadow + reflection; }
};

// raytrace.comp.glsl's ray structure with the same intersection math.
RayCounts predictRays(const scenes::Camera& camera, uint32_t sphereCount, uint32_t bounces) {
  const scenes::Bounds& b = testScene("atrium").gpu->bounds();
  const std::vector<glm::vec4> spheres = raytraceSpheres(b, sphereCount);
  const glm::vec3 light = raytraceLight(b);
  const float eps = raytraceEpsilon(b), groundY = b.min.y;
  auto trace = [&](glm::vec3 o, glm::vec3 d, float tMax, int& hit) {
    float best = tMax;
    hit = -1;
    for (size_t i = 0; i < spheres.size(); ++i) {
      glm::vec3 oc = o - glm::vec3(spheres[i]);
      float bb = glm::dot(oc, d);
      float c = glm::dot(oc, oc) - spheres[i].w * spheres[i].w;
      float h = bb * bb - c;
      if (h > 0.0f) {
        float t = -bb - std::sqrt(h);
        if (t > eps && t < best) {
          best = t;
          hit = int(i);
        }
      }
    }
    return best;
  };
  RayCounts out;
  for (uint32_t y = 0; y < kExtent.height; ++y) {
    for (uint32_t x = 0; x < kExtent.width; ++x) {
      Ray r = pixelRay(camera, x, y);
      glm::vec3 o = r.o, d = r.d;
      ++out.primary;
      for (uint32_t bounce = 0;; ++bounce) {
        int index;
        float t = trace(o, d, 1e30f, index);
        float tg = d.y < 0.0f ? (groundY - o.y) / d.y : 1e30f;
        bool ground = tg > eps && tg < t;
        if (index < 0 && !ground) break;
        glm::vec3 p, n;
        if (ground) {
          p = o + d * tg;
          n = {0, 1, 0};
        } else {
          p = o + d * t;
          n = (p - glm::vec3(spheres[index])) / spheres[index].w;
        }
        glm::vec3 toLight = light - p;
        float dist = glm::length(toLight);
        glm::vec3 q = p + n * eps;
        int blocker;
        trace(q, toLight / dist, dist, blocker);
        ++out.shadow;
        if (bounce >= bounces) break;
        d = glm::reflect(d, n);
        o = q;
        ++out.reflection;
      }
    }
  }
  return out;
}

const scenes::Bounds& atriumBounds() { return testScene("atrium").gpu->bounds(); }

std::function<void(RendererOptions&)> fogWith(FogOctaves mode, uint32_t steps, uint32_t maxOctaves, float density) {
  return [=](RendererOptions& o) {
    o.workload.fogOctaves = mode;
    o.workload.fogSteps = steps;
    o.workload.fogMaxOctaves = maxOctaves;
    o.workload.fogDensity = density;
  };
}

// ---------------------------------------------------------------- options, spec

TEST(WorkloadOptions, TableRefusesBadValuesNamingTheOption) {
  EXPECT_TRUE(isWorkload("volume-fog"));
  EXPECT_TRUE(isWorkload("raytrace"));
  EXPECT_FALSE(isWorkload("forward"));
  const std::vector<std::string> renderers = rendererNames();
  for (const auto& w : workloadNames()) {
    EXPECT_TRUE(makeRenderer(w).ok()) << w;
    EXPECT_EQ(std::find(renderers.begin(), renderers.end(), w), renderers.end()) << w;  // listed apart
  }
  auto ok = canonicalOptions("volume-fog", {{"octaves", "dynamic"}, {"fog_steps", 64}, {"fog_max_octaves", 4}});
  ASSERT_TRUE(ok.ok()) << ok.error();
  EXPECT_EQ(*ok, (nlohmann::json{{"octaves", "dynamic"}, {"fog_max_octaves", 4}}));  // fog_steps 64 is the default
  auto bad = canonicalOptions("volume-fog", {{"octaves", "sometimes"}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("octaves:", 0), 0u) << bad.error();
  bad = canonicalOptions("volume-fog", {{"fog_max_octaves", 9}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("fog_max_octaves:", 0), 0u) << bad.error();
  bad = canonicalOptions("volume-fog", {{"fog_density", 100.0}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("fog_density:", 0), 0u) << bad.error();
  bad = canonicalOptions("raytrace", {{"octaves", "fixed"}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("octaves:", 0), 0u) << bad.error();
  bad = canonicalOptions("raytrace", {{"bounces", 4}});
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().rfind("bounces:", 0), 0u) << bad.error();
  bad = canonicalOptions("forward", {{"spheres", 8}});
  ASSERT_FALSE(bad.ok());
  // The octave mode is the technique, compared against fixed; steps, octaves
  // and density are parameters the reference keeps.
  capture::RendererVariant dynamic{"volume-fog", {{"octaves", "dynamic"}, {"fog_max_octaves", 4}}};
  EXPECT_EQ(dynamic.reference().options, (nlohmann::json{{"fog_max_octaves", 4}}));
}

TEST(WorkloadSpec, WorkloadsBesideRenderers) {
  const nlohmann::json res = {{64, 36}};
  auto spec = capture::parseCaptureSpec(
      {{"renderers", {"forward"}},
       {"workloads", {"raytrace", {{"workload", "volume-fog"}, {"options", {{"octaves", "constant"}}}}}},
       {"resolutions", res}},
      rendererNames());
  ASSERT_TRUE(spec.ok()) << spec.error();
  ASSERT_EQ(spec->renderers.size(), 3u);
  EXPECT_EQ(spec->renderers[1].name, "raytrace");
  EXPECT_EQ(spec->renderers[2].label(), "volume-fog octaves=constant");
  // Workloads alone; "renderer" is accepted as the entry's key too.
  spec = capture::parseCaptureSpec({{"workloads", {{{"renderer", "volume-fog"}}}}, {"resolutions", res}}, rendererNames());
  ASSERT_TRUE(spec.ok()) << spec.error();
  EXPECT_EQ(spec->renderers.size(), 1u);

  auto error = [&](nlohmann::json j) {
    j["resolutions"] = res;
    auto parsed = capture::parseCaptureSpec(j, rendererNames());
    return parsed ? std::string() : parsed.error();
  };
  EXPECT_EQ(error({{"workloads", {"forward"}}}).rfind("workloads[0]: 'forward' is a renderer", 0), 0u);
  EXPECT_EQ(error({{"workloads", {"fog"}}}).rfind("workloads[0]: unknown workload 'fog'", 0), 0u);
  EXPECT_EQ(error({{"renderers", {"raytrace"}}}).rfind("renderers[0]: 'raytrace' is a workload", 0), 0u);
  EXPECT_EQ(error({{"workloads", {{{"workload", "volume-fog"}, {"options", {{"octaves", "x"}}}}}}})
                .rfind("workloads[0].options.octaves:", 0),
            0u);
  EXPECT_EQ(error({{"workloads", {{{"workload", "raytrace"}, {"options", {{"spheres", 7}}}}}}})
                .rfind("workloads[0].options.spheres:", 0),
            0u);
  EXPECT_EQ(error({{"workloads", nlohmann::json::array()}}).rfind("workloads:", 0), 0u);
  EXPECT_EQ(error({{"scenes", {"atrium"}}}).rfind("renderers: required", 0), 0u);
  EXPECT_EQ(error({{"workloads", {"raytrace", "raytrace"}}}).rfind("workloads[1]: workload 'raytrace' listed twice", 0),
            0u);
}

// ---------------------------------------------------------------- fog on the device

// Density 0: no opacity, no early termination; the camera inside the box, so
// every ray crosses it with exactly fog_steps samples. fixed and constant read
// pixels x steps x max octaves; dynamic the CPU replica's sum of
// clamp(max - floor(log2(t / t0)), 1, max) over the samples (tolerance: one
// octave per 10^4 reads, for samples whose t / t0 lands on a power of two
// within float rounding).
TEST(VolumeFog, CountedReadsEqualThePredictionWithoutTermination) {
  const scenes::Camera camera = insideCamera(atriumBounds());
  const uint32_t steps = 16, maxOctaves = 6;
  const uint64_t pixels = uint64_t(kExtent.width) * kExtent.height;
  for (FogOctaves mode : {FogOctaves::Fixed, FogOctaves::Constant, FogOctaves::Dynamic}) {
    SCOPED_TRACE(std::string(toString(mode)));
    auto adjust = fogWith(mode, steps, maxOctaves, 0.0f);
    WorkloadRun r = runWorkload("volume-fog", camera, adjust);
    ASSERT_TRUE(r.ok);
    EXPECT_EQ(r.passNames, (std::vector<std::string>{"fog", "tonemap"}));
    RendererOptions o;
    adjust(o);
    FogPrediction predicted = predictFog(camera, o.workload, false);
    ASSERT_EQ(predicted.rays, pixels);  // inside the box: every ray crosses it
    const uint64_t reads = readsOf(r, "fog", "fog_density");
    if (mode == FogOctaves::Dynamic) {
      EXPECT_LT(predicted.reads, pixels * steps * maxOctaves);  // far samples drop octaves
      EXPECT_GT(predicted.reads, pixels * steps);
      EXPECT_NEAR(double(reads), double(predicted.reads), double(predicted.reads) * 1e-4);
    } else {
      EXPECT_EQ(reads, pixels * steps * maxOctaves);
      EXPECT_EQ(predicted.reads, pixels * steps * maxOctaves);
    }
    EXPECT_EQ(writesOf(r, "fog", "hdr"), pixels);  // one imageStore per pixel
    const auto& fog = r.extras["fog"];
    EXPECT_EQ(fog["mode"], std::string(toString(mode)));
    EXPECT_EQ(fog["rays"].get<uint64_t>(), pixels);
    EXPECT_EQ(fog["samples"].get<uint64_t>(), pixels * steps);
    EXPECT_DOUBLE_EQ(fog["terminated_early_fraction"].get<double>(), 0.0);
    EXPECT_EQ(fog["reads"].get<uint64_t>(), reads);
    std::printf("fog %s: %llu reads (predicted %llu), %.2f per ray\n", std::string(toString(mode)).c_str(),
                (unsigned long long)reads, (unsigned long long)predicted.reads,
                fog["reads_per_ray_mean"].get<double>());
  }
}

// A dense volume: rays stop once the opacity reaches 0.99. The reads fall
// below the no-termination bound and match the CPU replica (trilinear
// sampling of the same texels; the device's filtering precision moves a few
// rays' stopping sample by one: tolerance 3% of the reads and samples).
TEST(VolumeFog, EarlyTerminationMatchesTheReplica) {
  const scenes::Camera camera = outsideCamera(atriumBounds());
  const uint32_t steps = 64, maxOctaves = 4;
  for (FogOctaves mode : {FogOctaves::Fixed, FogOctaves::Dynamic}) {
    SCOPED_TRACE(std::string(toString(mode)));
    auto adjust = fogWith(mode, steps, maxOctaves, 24.0f);
    WorkloadRun r = runWorkload("volume-fog", camera, adjust);
    ASSERT_TRUE(r.ok);
    RendererOptions o;
    adjust(o);
    FogPrediction predicted = predictFog(camera, o.workload, true);
    FogPrediction bound = predictFog(camera, o.workload, false);
    const uint64_t reads = readsOf(r, "fog", "fog_density");
    ASSERT_GT(predicted.rays, 0u);
    EXPECT_LT(predicted.rays, uint64_t(kExtent.width) * kExtent.height);  // some rays miss the box
    EXPECT_LT(predicted.reads, bound.reads / 2);  // termination matters in this configuration
    EXPECT_LT(reads, bound.reads);
    EXPECT_NEAR(double(reads), double(predicted.reads), double(predicted.reads) * 0.03);
    const auto& fog = r.extras["fog"];
    EXPECT_EQ(fog["rays"].get<uint64_t>(), predicted.rays);
    EXPECT_NEAR(double(fog["samples"].get<uint64_t>()), double(predicted.samples), double(predicted.samples) * 0.03);
    EXPECT_GT(fog["terminated_early_fraction"].get<double>(), 0.5);
    std::printf("fog dense %s: %llu reads (replica %llu, no-termination bound %llu), %.3f terminated early\n",
                std::string(toString(mode)).c_str(), (unsigned long long)reads,
                (unsigned long long)predicted.reads, (unsigned long long)bound.reads,
                fog["terminated_early_fraction"].get<double>());
  }
}

// The modes' images against the fixed-maximum reference at the default
// density: constant is the same math unrolled (max channel difference at most
// 2 of 255: float rounding of a reordered sum); dynamic drops far octaves for
// their mean (PSNR at least 30 dB, mean channel difference under 2; lavapipe:
// max 1, 62.9 dB).
TEST(VolumeFog, ImagesAgreeAcrossOctaveModes) {
  const scenes::Camera camera = insideCamera(atriumBounds());
  WorkloadRun fixed = runWorkload("volume-fog", camera, fogWith(FogOctaves::Fixed, 32, 6, 1.0f));
  WorkloadRun constant = runWorkload("volume-fog", camera, fogWith(FogOctaves::Constant, 32, 6, 1.0f));
  WorkloadRun dynamic = runWorkload("volume-fog", camera, fogWith(FogOctaves::Dynamic, 32, 6, 1.0f));
  ASSERT_TRUE(fixed.ok && constant.ok && dynamic.ok);
  auto c = analysis::compareImages(constant.image, fixed.image, kExtent.width, kExtent.height);
  auto d = analysis::compareImages(dynamic.image, fixed.image, kExtent.width, kExtent.height);
  ASSERT_TRUE(c.ok() && d.ok());
  EXPECT_LE(c->maxAbs, 2);
  EXPECT_GE(d->psnr, 30.0);
  EXPECT_LT(d->meanAbs, 2.0);
  std::printf("fog images vs fixed: constant max %d psnr %.1f; dynamic max %d mean %.3f psnr %.1f\n", c->maxAbs,
              c->psnr, d->maxAbs, d->meanAbs, d->psnr);
}

// ---------------------------------------------------------------- ray tracer

// Every ray tests every sphere once: the counted reads of "spheres" equal the
// rays the shader reports per pixel x spheres exactly, and the CPU replica's
// rays (same intersection math in C++) within 0.5% (rays grazing a sphere or
// the shadow boundary can go either way in float).
TEST(Raytrace, SphereReadsAreRaysTimesSpheres) {
  const scenes::Camera camera = outsideCamera(atriumBounds());
  for (uint32_t bounces : {0u, 2u}) {
    const uint32_t spheres = 16;
    SCOPED_TRACE("bounces " + std::to_string(bounces));
    WorkloadRun r = runWorkload("raytrace", camera, [&](RendererOptions& o) {
      o.workload.spheres = spheres;
      o.workload.bounces = bounces;
    });
    ASSERT_TRUE(r.ok);
    EXPECT_EQ(r.passNames, (std::vector<std::string>{"raytrace", "tonemap"}));
    const uint64_t pixels = uint64_t(kExtent.width) * kExtent.height;
    const uint64_t reads = readsOf(r, "raytrace", "spheres");
    const auto& rays = r.extras["raytrace"]["rays"];
    EXPECT_EQ(rays["primary"].get<uint64_t>(), pixels);
    EXPECT_EQ(reads, rays["total"].get<uint64_t>() * spheres);
    EXPECT_EQ(r.extras["raytrace"]["sphere_reads"].get<uint64_t>(), reads);
    RayCounts predicted = predictRays(camera, spheres, bounces);
    EXPECT_GT(predicted.shadow, 0u);
    if (bounces == 0) {
      EXPECT_EQ(predicted.reflection, 0u);
    } else {
      EXPECT_GT(predicted.reflection, 0u);
    }
    EXPECT_NEAR(double(reads), double(predicted.total() * spheres), double(predicted.total() * spheres) * 0.005);
    EXPECT_NEAR(double(rays["shadow"].get<uint64_t>()), double(predicted.shadow), double(predicted.shadow) * 0.005);
    EXPECT_NEAR(double(rays["reflection"].get<uint64_t>()), double(predicted.reflection),
                double(predicted.reflection) * 0.005 + 0.5);
    EXPECT_EQ(writesOf(r, "raytrace", "hdr"), pixels);
    std::printf("raytrace bounces %u: %llu sphere reads; rays %llu primary %llu shadow %llu reflection (replica %llu "
                "%llu %llu)\n",
                bounces, (unsigned long long)reads, (unsigned long long)rays["primary"].get<uint64_t>(),
                (unsigned long long)rays["shadow"].get<uint64_t>(),
                (unsigned long long)rays["reflection"].get<uint64_t>(), (unsigned long long)predicted.primary,
                (unsigned long long)predicted.shadow, (unsigned long long)predicted.reflection);
  }
}

}  // namespace
}  // namespace tally::renderers
