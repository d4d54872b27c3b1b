#include "scenes/textures.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace tally::scenes {

const char* toString(ProceduralMaterial kind) {
  switch (kind) {
    case ProceduralMaterial::Stone: return "stone";
    case ProceduralMaterial::Brick: return "brick";
    case ProceduralMaterial::Tiles: return "tiles";
    case ProceduralMaterial::Wood: return "wood";
    case ProceduralMaterial::Fabric: return "fabric";
    case ProceduralMaterial::Plaster: return "plaster";
  }
  return "?";
}

uint32_t texelHash(uint32_t x, uint32_t y, uint32_t seed) {
  uint32_t h = x * 0x8da6b343u ^ y * 0xd8163841u ^ seed * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

namespace {

constexpr float kPi = 3.14159265358979f;


float hash01(uint32_t x, uint32_t y, uint32_t seed) {
  return float(texelHash(x, y, seed) >> 8) * (1.0f / 16777216.0f);
}

// Value noise on a lattice of `period` cells per unit, wrapping so the result
// tiles over [0, 1).
float valueNoise(float u, float v, uint32_t period, uint32_t seed) {
  float x = u * float(period), y = v * float(period);
  float fx = std::floor(x), fy = std::floor(y);
  float tx = x - fx, ty = y - fy;
  tx = tx * tx * (3.0f - 2.0f * tx);
  ty = ty * ty * (3.0f - 2.0f * ty);
  auto wrap = [period](float c) { return uint32_t(((int64_t(c) % period) + period) % period); };
  uint32_t x0 = wrap(fx), y0 = wrap(fy), x1 = wrap(fx + 1), y1 = wrap(fy + 1);
  float a = hash01(x0, y0, seed), b = hash01(x1, y0, seed);
  float c = hash01(x0, y1, seed), d = hash01(x1, y1, seed);
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * ty;
}

// Fractal sum, octaves doubling the frequency; result in [0, 1].
float fbm(float u, float v, uint32_t period, int octaves, uint32_t seed) {
  float sum = 0.0f, amp = 0.5f, norm = 0.0f;
  for (int i = 0; i < octaves; ++i) {
    sum += amp * valueNoise(u, v, period << i, seed + uint32_t(i) * 101u);
    norm += amp;
    amp *= 0.5f;
  }
  return sum / norm;
}

float smooth(float e0, float e1, float x) {
  float t = std::clamp((x - e0) / (e1 - e0), 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

glm::vec3 mix(const glm::vec3& a, const glm::vec3& b, float t) { return a + (b - a) * t; }

// What the height function yields per texel; colours are sRGB-encoded [0, 1].
struct Texel {
  float height = 0.5f;  // 0 = deepest groove, 1 = top surface
  glm::vec3 albedo{0.5f};
  float specular = 0.2f;
  float roughness = 0.8f;
};

// Distance from (u, v) to the nearest joint of a running-bond grid with
// `rows` courses and `cols` units per course, in units of the course height;
// also returns the unit's id.
float jointDistance(float u, float v, float rows, float cols, bool stagger, uint32_t* id) {
  float y = v * rows;
  float row = std::floor(y);
  float x = u * cols + (stagger && int(row) % 2 ? 0.5f : 0.0f);
  float col = std::floor(x);
  *id = uint32_t(int(row)) * 131u + uint32_t(int(std::fmod(col + cols, cols)));
  float dy = std::min(y - row, row + 1.0f - y);
  float dx = std::min(x - col, col + 1.0f - x) * rows / cols;  // in course-height units
  return std::min(dx, dy);
}

Texel stone(float u, float v) {
  uint32_t id = 0;
  float joint = jointDistance(u, v, 4.0f, 2.0f, true, &id);  // large ashlar blocks
  float n = fbm(u, v, 8, 5, 11);
  Texel t;
  t.height = 0.15f + 0.85f * smooth(0.0f, 0.04f, joint) * (0.75f + 0.25f * n);
  float tint = hash01(id, 0, 12) * 0.12f;
  t.albedo = mix(glm::vec3(0.62f, 0.58f, 0.50f), glm::vec3(0.78f, 0.74f, 0.66f), n) - glm::vec3(tint);
  t.specular = 0.15f + 0.1f * n;
  t.roughness = 0.75f + 0.2f * (1.0f - n);
  return t;
}

Texel brick(float u, float v) {
  uint32_t id = 0;
  float joint = jointDistance(u, v, 8.0f, 4.0f, true, &id);
  float n = fbm(u, v, 16, 4, 21);
  float mortar = 1.0f - smooth(0.04f, 0.08f, joint);
  Texel t;
  t.height = (1.0f - mortar) * (0.7f + 0.3f * n) + mortar * 0.1f;
  glm::vec3 brickColor =
      mix(glm::vec3(0.55f, 0.24f, 0.16f), glm::vec3(0.70f, 0.36f, 0.24f), hash01(id, 1, 22));
  brickColor *= 0.85f + 0.3f * n;
  t.albedo = mix(brickColor, glm::vec3(0.72f, 0.70f, 0.66f), mortar);
  t.specular = 0.1f + 0.1f * (1.0f - mortar);
  t.roughness = 0.85f + 0.1f * mortar;
  return t;
}

Texel tiles(float u, float v) {
  uint32_t id = 0;
  float joint = jointDistance(u, v, 4.0f, 4.0f, false, &id);
  float n = fbm(u, v, 8, 5, 31);
  float grout = 1.0f - smooth(0.02f, 0.05f, joint);
  bool dark = ((int(u * 4.0f) + int(v * 4.0f)) & 1) != 0;
  Texel t;
  t.height = (1.0f - grout) * (0.9f + 0.1f * n) + grout * 0.2f;
  glm::vec3 tile = dark ? glm::vec3(0.35f, 0.30f, 0.27f) : glm::vec3(0.85f, 0.82f, 0.76f);
  // Marble veins: a sine of a noise-warped coordinate.
  float vein = std::pow(std::abs(std::sin((u + v + n * 0.6f) * 6.0f * kPi)), 8.0f);
  tile = mix(tile, tile * 0.7f, vein * 0.5f);
  t.albedo = mix(tile, glm::vec3(0.45f, 0.43f, 0.40f), grout);
  t.specular = grout > 0.5f ? 0.05f : 0.6f;
  t.roughness = grout > 0.5f ? 0.9f : 0.25f + 0.15f * n;
  return t;
}

Texel wood(float u, float v) {
  // Four planks across u, grain running along v.
  float x = u * 4.0f;
  float plank = std::floor(x);
  float edge = std::min(x - plank, plank + 1.0f - x);
  float n = fbm(u, v, 4, 4, 41 + uint32_t(plank));
  float grain =
      0.5f + 0.5f * std::sin((x * 9.0f + n * 3.0f + hash01(uint32_t(plank), 0, 42) * 5.0f) * 2.0f * kPi);
  float seam = 1.0f - smooth(0.0f, 0.03f, edge);
  Texel t;
  t.height = (1.0f - seam) * (0.8f + 0.2f * grain) + seam * 0.2f;
  t.albedo = mix(glm::vec3(0.42f, 0.26f, 0.14f), glm::vec3(0.62f, 0.42f, 0.24f), grain * 0.7f + n * 0.3f);
  t.albedo *= 1.0f - 0.5f * seam;
  t.specular = 0.3f + 0.2f * grain;
  t.roughness = 0.45f + 0.3f * (1.0f - grain);
  return t;
}

Texel fabric(float u, float v) {
  // Plain weave: warp and weft threads alternating over and under.
  constexpr float kThreads = 64.0f;
  float su = std::sin(u * kThreads * kPi), sv = std::sin(v * kThreads * kPi);
  bool warpOnTop = ((int(u * kThreads) + int(v * kThreads)) & 1) != 0;
  float h = warpOnTop ? std::abs(su) : std::abs(sv);
  float n = fbm(u, v, 8, 3, 51);
  // A banner: a border stripe and a central band.
  float stripe = std::abs(u - 0.5f) > 0.42f || std::abs(v - 0.5f) < 0.06f ? 1.0f : 0.0f;
  Texel t;
  t.height = 0.3f + 0.7f * h;
  t.albedo = mix(glm::vec3(0.55f, 0.08f, 0.08f), glm::vec3(0.85f, 0.68f, 0.22f), stripe) *
             (0.8f + 0.2f * h + 0.1f * n);
  t.specular = 0.05f + 0.1f * stripe + 0.05f * h;
  t.roughness = 0.8f + 0.15f * (1.0f - h);
  return t;
}

Texel plaster(float u, float v) {
  float n = fbm(u, v, 4, 6, 61);
  Texel t;
  t.height = n;
  t.albedo = mix(glm::vec3(0.80f, 0.77f, 0.70f), glm::vec3(0.90f, 0.88f, 0.82f), n);
  t.specular = 0.08f + 0.06f * n;
  t.roughness = 0.85f + 0.1f * (1.0f - n);
  return t;
}

Texel evaluate(ProceduralMaterial kind, float u, float v) {
  switch (kind) {
    case ProceduralMaterial::Stone: return stone(u, v);
    case ProceduralMaterial::Brick: return brick(u, v);
    case ProceduralMaterial::Tiles: return tiles(u, v);
    case ProceduralMaterial::Wood: return wood(u, v);
    case ProceduralMaterial::Fabric: return fabric(u, v);
    case ProceduralMaterial::Plaster: return plaster(u, v);
  }
  return {};
}

// Normal-map slope per unit of height change between neighbouring texels of
// a 256-texel map (scaled with the map size): strong enough to read as relief,
// gentle enough that no normal tips over.
float bumpStrength(ProceduralMaterial kind) {
  switch (kind) {
    case ProceduralMaterial::Fabric: return 1.5f;
    case ProceduralMaterial::Plaster: return 3.0f;
    default: return 6.0f;
  }
}

uint8_t toByte(float x) { return uint8_t(std::lround(std::clamp(x, 0.0f, 1.0f) * 255.0f)); }

Texture makeMap(const std::string& name, uint32_t size, bool srgb) {
  Texture t;
  t.name = name;
  t.width = t.height = size;
  t.srgb = srgb;
  t.rgba8.resize(size_t(size) * size * 4);
  return t;
}

void put(Texture& t, uint32_t x, uint32_t y, glm::vec3 rgb) {
  uint8_t* p = &t.rgba8[(size_t(y) * t.width + x) * 4];
  p[0] = toByte(rgb.r);
  p[1] = toByte(rgb.g);
  p[2] = toByte(rgb.b);
  p[3] = 255;
}

}  // namespace

uint32_t addProceduralMaterial(Scene& scene, ProceduralMaterial kind, uint32_t size) {
  const std::string name = toString(kind);
  std::vector<Texel> texels(size_t(size) * size);
  for (uint32_t y = 0; y < size; ++y)
    for (uint32_t x = 0; x < size; ++x)
      texels[size_t(y) * size + x] =
          evaluate(kind, (float(x) + 0.5f) / float(size), (float(y) + 0.5f) / float(size));

  Texture diffuse = makeMap(name + "/diffuse", size, true);
  Texture ambient = makeMap(name + "/ambient", size, false);
  Texture specular = makeMap(name + "/specular", size, false);
  Texture roughness = makeMap(name + "/roughness", size, false);
  Texture normal = makeMap(name + "/normal", size, false);
  const float strength = bumpStrength(kind) * float(size) / 256.0f;
  auto height = [&](int x, int y) {
    int s = int(size);
    return texels[size_t((y + s) % s) * size + size_t((x + s) % s)].height;
  };
  for (uint32_t y = 0; y < size; ++y) {
    for (uint32_t x = 0; x < size; ++x) {
      const Texel& t = texels[size_t(y) * size + x];
      put(diffuse, x, y, t.albedo);
      // Occlusion: grooves see less of the sky than the top surface.
      put(ambient, x, y, glm::vec3(0.35f + 0.65f * smooth(0.0f, 0.7f, t.height)));
      put(specular, x, y, glm::vec3(t.specular));
      put(roughness, x, y, glm::vec3(t.roughness));
      // Tangent space: +x along +u, +y along +v (the tangent and bitangent
      // that computeTangents derives), +z out of the surface.
      float du = (height(int(x) + 1, int(y)) - height(int(x) - 1, int(y))) * 0.5f;
      float dv = (height(int(x), int(y) + 1) - height(int(x), int(y) - 1)) * 0.5f;
      glm::vec3 n = glm::normalize(glm::vec3(-du * strength, -dv * strength, 1.0f));
      put(normal, x, y, n * 0.5f + 0.5f);
    }
  }

  Material m;
  m.name = name;
  const auto first = int32_t(scene.textures.size());
  for (size_t i = 0; i < kMapSlotCount; ++i) m.maps[i] = first + int32_t(i);
  // The procedural scenes are drawn without back-face culling, as the
  // founding study drew them (their counts and the analytic tests assume it).
  m.doubleSided = true;
  // Order matches MapSlot: Diffuse, Ambient, Specular, Roughness, Normal.
  scene.textures.push_back(std::move(diffuse));
  scene.textures.push_back(std::move(ambient));
  scene.textures.push_back(std::move(specular));
  scene.textures.push_back(std::move(roughness));
  scene.textures.push_back(std::move(normal));
  scene.materials.push_back(std::move(m));
  return uint32_t(scene.materials.size() - 1);
}

}  // namespace tally::scenes
