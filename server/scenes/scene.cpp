#include "scenes/scene.hpp"

#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

namespace tally::scenes {

const char* toString(MapSlot slot) {
  switch (slot) {
    case MapSlot::Diffuse: return "diffuse";
    case MapSlot::Ambient: return "ambient";
    case MapSlot::Specular: return "specular";
    case MapSlot::Roughness: return "roughness";
    case MapSlot::Normal: return "normal";
  }
  return "?";
}

const char* toString(Wrap wrap) {
  switch (wrap) {
    case Wrap::Repeat: return "repeat";
    case Wrap::MirroredRepeat: return "mirrored_repeat";
    case Wrap::ClampToEdge: return "clamp_to_edge";
  }
  return "?";
}

glm::mat3x2 UvTransform::matrix() const {
  const float c = std::cos(rotation), s = std::sin(rotation);
  // KHR_texture_transform: T * R * S with R = [c s; -s c] (rows), so
  // u' = c*sx*u + s*sy*v + ox, v' = -s*sx*u + c*sy*v + oy.
  return glm::mat3x2(glm::vec2(c * scale.x, -s * scale.x), glm::vec2(s * scale.y, c * scale.y), offset);
}

Scene::Features Scene::features() const {
  Features f;
  std::vector<bool> drawn(materials.size(), false);
  for (const Mesh& m : meshes) {
    if (m.material < drawn.size()) drawn[m.material] = true;
    f.vertexColors = f.vertexColors || !m.colors.empty();
  }
  for (size_t i = 0; i < materials.size(); ++i) {
    if (!drawn[i]) continue;
    const Material& m = materials[i];
    f.alphaMask = f.alphaMask || m.alphaMode == AlphaMode::Mask;
    f.alphaBlend = f.alphaBlend || m.alphaMode == AlphaMode::Blend;
    f.singleSided = f.singleSided || !m.doubleSided;
    f.emissive = f.emissive || m.emissive();
    f.emissiveMaps = f.emissiveMaps || (m.emissive() && m.emissiveMap >= 0);
    for (size_t k = 0; k < kMapSlotCount; ++k) {
      if (m.maps[k] < 0) continue;
      f.uv1 = f.uv1 || m.texCoord[k] == 1;
      f.uvTransform = f.uvTransform || !m.transform[k].identity();
    }
    if (m.emissive() && m.emissiveMap >= 0) {
      f.uv1 = f.uv1 || m.emissiveTexCoord == 1;
      f.uvTransform = f.uvTransform || !m.emissiveTransform.identity();
    }
  }
  return f;
}

size_t Scene::triangleCount() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.triangleCount();
  return n;
}

size_t Scene::vertexCount() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.vertices.size();
  return n;
}

glm::mat4 viewMatrix(const Camera& camera) {
  glm::vec3 dir = glm::normalize(camera.target - camera.eye);
  glm::vec3 up(0.0f, 1.0f, 0.0f);
  // sin(0.5 deg) ~ 0.0087: closer to vertical than that, lookAt's basis degrades.
  if (glm::length(glm::cross(dir, up)) < 0.0087f)
    up = dir.y > 0.0f ? glm::vec3(0, 0, -1) : glm::vec3(0, 0, 1);
  return glm::lookAt(camera.eye, camera.target, up);
}

void updateBounds(Mesh& mesh) {
  mesh.bounds = Bounds{};
  for (const Vertex& v : mesh.vertices) mesh.bounds.extend(v.position);
}

void updateBounds(Scene& scene) {
  scene.bounds = Bounds{};
  for (Mesh& m : scene.meshes) {
    updateBounds(m);
    scene.bounds.extend(m.bounds);
  }
}

namespace {

// Any unit vector orthogonal to n (Frisvad-style branch on the largest axis).
glm::vec3 anyOrthogonal(const glm::vec3& n) {
  glm::vec3 axis = std::abs(n.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  return glm::normalize(axis - n * glm::dot(n, axis));
}

}  // namespace

void computeTangents(Mesh& mesh) {
  std::vector<glm::vec3> tan(mesh.vertices.size(), glm::vec3(0.0f));
  std::vector<glm::vec3> bitan(mesh.vertices.size(), glm::vec3(0.0f));
  for (size_t i = 0; i + 2 < mesh.indices.size(); i += 3) {
    uint32_t ia = mesh.indices[i], ib = mesh.indices[i + 1], ic = mesh.indices[i + 2];
    const Vertex& a = mesh.vertices[ia];
    const Vertex& b = mesh.vertices[ib];
    const Vertex& c = mesh.vertices[ic];
    glm::vec3 e1 = b.position - a.position, e2 = c.position - a.position;
    glm::vec2 d1 = b.uv - a.uv, d2 = c.uv - a.uv;
    float det = d1.x * d2.y - d2.x * d1.y;
    if (std::abs(det) < 1e-12f) continue;  // degenerate UVs: no direction to take
    // Directions from the UV mapping, each rescaled to the triangle's area so
    // large triangles dominate and tiny UV islands cannot blow up the sum.
    float r = 1.0f / det;
    glm::vec3 t = (e1 * d2.y - e2 * d1.y) * r;
    glm::vec3 bt = (e2 * d1.x - e1 * d2.x) * r;
    float area = glm::length(glm::cross(e1, e2));
    float tl = glm::length(t), bl = glm::length(bt);
    if (!(tl > 0.0f) || !(bl > 0.0f) || !std::isfinite(tl) || !std::isfinite(bl)) continue;
    t *= area / tl;
    bt *= area / bl;
    for (uint32_t idx : {ia, ib, ic}) {
      tan[idx] += t;
      bitan[idx] += bt;
    }
  }
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    Vertex& v = mesh.vertices[i];
    const glm::vec3 n = v.normal;
    glm::vec3 t = tan[i] - n * glm::dot(n, tan[i]);
    float len = glm::length(t);
    if (len < 1e-6f || !std::isfinite(len)) {
      v.tangent = glm::vec4(anyOrthogonal(n), 1.0f);
      continue;
    }
    t /= len;
    float w = glm::dot(glm::cross(n, t), bitan[i]) < 0.0f ? -1.0f : 1.0f;
    v.tangent = glm::vec4(t, w);
  }
}

namespace {

struct Fnv {
  uint64_t h = 1469598103934665603ull;
  void add(const void* data, size_t size) {
    const auto* p = static_cast<const uint8_t*>(data);
    for (size_t i = 0; i < size; ++i) {
      h ^= p[i];
      h *= 1099511628211ull;
    }
  }
};

}  // namespace

uint64_t contentHash(const Scene& scene) {
  Fnv f;
  for (const Mesh& m : scene.meshes) {
    f.add(m.vertices.data(), m.vertices.size() * sizeof(Vertex));
    f.add(m.indices.data(), m.indices.size() * sizeof(uint32_t));
    f.add(&m.material, sizeof(m.material));
  }
  for (const Texture& t : scene.textures) f.add(t.rgba8.data(), t.rgba8.size());
  return f.h;
}

nlohmann::json toJson(const Camera& camera) {
  nlohmann::json j = {
      {"eye", {camera.eye.x, camera.eye.y, camera.eye.z}},
      {"target", {camera.target.x, camera.target.y, camera.target.z}},
      {"fov_deg", camera.fovDeg},
  };
  if (camera.skyFraction >= 0.0f) j["sky_fraction"] = camera.skyFraction;
  if (!camera.label.empty()) j["label"] = camera.label;
  return j;
}

}  // namespace tally::scenes
