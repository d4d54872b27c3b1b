// The workloads' options and the CPU side of their shaders' math (density
// texels, fog volume, rays, spheres) that the tests derive counts from.
#include "renderers/workloads/workloads.hpp"

#include <algorithm>
#include <cmath>

namespace tally::renderers {

using nlohmann::json;

std::string_view toString(FogOctaves mode) {
  switch (mode) {
    case FogOctaves::Fixed: return "fixed";
    case FogOctaves::Dynamic: return "dynamic";
    case FogOctaves::Constant: return "constant";
  }
  return "fixed";
}

std::optional<FogOctaves> parseFogOctaves(std::string_view name) {
  for (auto m : {FogOctaves::Fixed, FogOctaves::Dynamic, FogOctaves::Constant}) {
    if (name == toString(m)) return m;
  }
  return std::nullopt;
}

void addWorkloadOptions(std::vector<OptionDef>& defs) {
  defs.push_back({"octaves",
                  {"volume-fog"},
                  {"fixed", "dynamic", "constant"},
                  {},
                  nullptr,
                  "Octaves of the fog density per ray-march sample: fixed (a loop to fog_max_octaves read from a "
                  "uniform: the reference), dynamic (clamp(max - floor(log2(t / t0)), 1, max) from the sample's "
                  "distance: a runtime loop bound) or constant (the maximum as a compile-time #define the "
                  "compiler may unroll)",
                  "fixed",
                  [](RendererOptions& o, const json& v) { o.workload.fogOctaves = *parseFogOctaves(v.get<std::string>()); }});
  defs.push_back({"fog_steps",
                  {"volume-fog"},
                  {64, 8, 16, 32, 128, 256},
                  {},
                  nullptr,
                  "Samples per ray between the fog box's entry and exit (fewer where the opacity reaches 0.99 first)",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.workload.fogSteps = v.get<uint32_t>(); }});
  defs.back().parameter = true;
  defs.push_back({"fog_max_octaves",
                  {"volume-fog"},
                  {6, 1, 2, 3, 4, 5, 7, 8},
                  {},
                  nullptr,
                  "The most octaves (3D texture reads) per sample, at doubling frequency and halving amplitude",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.workload.fogMaxOctaves = v.get<uint32_t>(); }});
  defs.back().parameter = true;
  defs.push_back({"fog_density",
                  {"volume-fog"},
                  {},
                  {0.0, 64.0},
                  1.0,
                  "Extinction scale: optical depth along the scene's diagonal at mean density is about 2 x this",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.workload.fogDensity = v.get<float>(); }});
  defs.back().parameter = true;
  defs.push_back({"spheres",
                  {"raytrace"},
                  {32, 8, 16, 64, 128, 256},
                  {},
                  nullptr,
                  "Spheres in the ray tracer's storage buffer; every ray tests every sphere",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.workload.spheres = v.get<uint32_t>(); }});
  defs.back().parameter = true;
  defs.push_back({"bounces",
                  {"raytrace"},
                  {1, 0, 2, 3},
                  {},
                  nullptr,
                  "Specular reflection rays after the primary hit (each hit also casts one shadow ray)",
                  nullptr,
                  [](RendererOptions& o, const json& v) { o.workload.bounces = v.get<uint32_t>(); }});
  defs.back().parameter = true;
}

namespace {

uint32_t hash(uint32_t x) {  // lowbias32
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}

float hashUnit(uint32_t x) { return float(hash(x) >> 8) / float(1u << 24); }

}  // namespace

std::vector<uint8_t> fogDensityTexels() {
  const uint32_t n = kFogTextureSize;
  std::vector<float> noise(size_t(n) * n * n);
  for (uint32_t i = 0; i < noise.size(); ++i) noise[i] = hashUnit(i * 2654435761u + 12345u);
  // Two periodic 3x3x3 box blurs: smooth, still tiling.
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<float> out(noise.size());
    for (uint32_t z = 0; z < n; ++z) {
      for (uint32_t y = 0; y < n; ++y) {
        for (uint32_t x = 0; x < n; ++x) {
          float sum = 0;
          for (int dz = -1; dz <= 1; ++dz) {
            for (int dy = -1; dy <= 1; ++dy) {
              for (int dx = -1; dx <= 1; ++dx) {
                uint32_t xx = (x + n + dx) % n, yy = (y + n + dy) % n, zz = (z + n + dz) % n;
                sum += noise[(size_t(zz) * n + yy) * n + xx];
              }
            }
          }
          out[(size_t(z) * n + y) * n + x] = sum / 27.0f;
        }
      }
    }
    noise = std::move(out);
  }
  // Stretch the blurred values (around 0.5, narrow) back over [0, 1].
  std::vector<uint8_t> texels(noise.size());
  for (size_t i = 0; i < noise.size(); ++i) {
    float v = std::clamp(0.5f + (noise[i] - 0.5f) * 5.0f, 0.0f, 1.0f);
    texels[i] = uint8_t(std::lround(v * 255.0f));
  }
  return texels;
}

FogVolume fogVolumeFor(const scenes::Bounds& bounds, float densityOption) {
  FogVolume v;
  v.min = bounds.min;
  v.max = bounds.max;
  const float diagonal = std::max(glm::length(bounds.max - bounds.min), 1e-3f);
  v.tileSize = diagonal / 4.0f;
  v.t0 = diagonal / 32.0f;
  v.sigmaScale = densityOption * 4.0f / diagonal;
  return v;
}

uint32_t fogDynamicOctaves(float t, float t0, uint32_t maxOctaves) {
  int n = int(maxOctaves) - int(std::floor(std::log2(t / t0)));
  return uint32_t(std::clamp(n, 1, int(maxOctaves)));
}

glm::vec3 workloadRayDirection(const glm::mat4& view, const glm::mat4& proj, glm::vec2 viewport, uint32_t x,
                               uint32_t y) {
  glm::vec2 ndc = (glm::vec2(float(x), float(y)) + 0.5f) * (1.0f / viewport) * 2.0f - 1.0f;
  glm::vec3 v(ndc.x / proj[0][0], ndc.y / proj[1][1], -1.0f);
  return glm::normalize(glm::transpose(glm::mat3(view)) * v);
}

std::vector<glm::vec4> raytraceSpheres(const scenes::Bounds& bounds, uint32_t count) {
  std::vector<glm::vec4> out;
  const glm::vec3 size = bounds.max - bounds.min;
  const float diagonal = std::max(glm::length(size), 1e-3f);
  for (uint32_t i = 0; i < count; ++i) {
    float r = diagonal * (0.015f + 0.025f * hashUnit(4 * i + 1));
    float x = bounds.min.x + size.x * (0.1f + 0.8f * hashUnit(4 * i + 2));
    float z = bounds.min.z + size.z * (0.1f + 0.8f * hashUnit(4 * i + 3));
    // Most rest on the ground; every fourth floats at up to half the height.
    float lift = (i % 4 == 3) ? size.y * 0.5f * hashUnit(4 * i + 4) : 0.0f;
    out.emplace_back(x, bounds.min.y + r + lift, z, r);
  }
  return out;
}

glm::vec3 raytraceLight(const scenes::Bounds& bounds) {
  glm::vec3 c = (bounds.min + bounds.max) * 0.5f;
  return {c.x + 0.2f * (bounds.max.x - bounds.min.x), bounds.max.y, c.z + 0.1f * (bounds.max.z - bounds.min.z)};
}

float raytraceEpsilon(const scenes::Bounds& bounds) {
  return std::max(glm::length(bounds.max - bounds.min), 1e-3f) * 1e-4f;
}

}  // namespace tally::renderers
