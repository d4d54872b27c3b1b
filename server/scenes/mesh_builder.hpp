// Internal helper of the procedural scenes: indexed triangles with flat or
// given normals, planar UVs anchored in world space (so textures run on across
// pieces), and windings fixed up to face a given normal.
#pragma once

#include <cstdint>
#include <string>
#include <utility>

#include "scenes/scene.hpp"

namespace tally::scenes {

class MeshBuilder {
 public:
  uint32_t vertex(const glm::vec3& p, const glm::vec3& n, const glm::vec2& uv) {
    mesh_.vertices.push_back({p, n, glm::vec4(0.0f), uv});
    return uint32_t(mesh_.vertices.size() - 1);
  }

  // Emits the triangle counter-clockwise as seen from the side `facing` points to.
  void triangle(uint32_t a, uint32_t b, uint32_t c, const glm::vec3& facing) {
    const glm::vec3& pa = mesh_.vertices[a].position;
    glm::vec3 n = glm::cross(mesh_.vertices[b].position - pa, mesh_.vertices[c].position - pa);
    if (glm::dot(n, facing) < 0.0f) std::swap(b, c);
    mesh_.indices.insert(mesh_.indices.end(), {a, b, c});
  }

  // UV of p for a face whose texture runs along uAxis (u) and vAxis (up in the
  // image, so v decreases along it), `tile` metres per repeat.
  static glm::vec2 planarUv(const glm::vec3& p, const glm::vec3& uAxis, const glm::vec3& vAxis, float tile) {
    return glm::vec2(glm::dot(p, uAxis), -glm::dot(p, vAxis)) / tile;
  }

  // Planar quad a, b, c, d (in order around its edge) facing n.
  void quad(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c, const glm::vec3& d,
            const glm::vec3& n, const glm::vec3& uAxis, const glm::vec3& vAxis, float tile) {
    uint32_t i0 = vertex(a, n, planarUv(a, uAxis, vAxis, tile));
    uint32_t i1 = vertex(b, n, planarUv(b, uAxis, vAxis, tile));
    uint32_t i2 = vertex(c, n, planarUv(c, uAxis, vAxis, tile));
    uint32_t i3 = vertex(d, n, planarUv(d, uAxis, vAxis, tile));
    triangle(i0, i1, i2, n);
    triangle(i0, i2, i3, n);
  }

  // Axis-aligned box; `faces` bit i (0..5: -x, +x, -y, +y, -z, +z) selects a face.
  void box(const glm::vec3& lo, const glm::vec3& hi, float tile, uint32_t faces = 0x3f) {
    const glm::vec3 X(1, 0, 0), Y(0, 1, 0), Z(0, 0, 1);
    auto p = [&](int x, int y, int z) {
      return glm::vec3(x ? hi.x : lo.x, y ? hi.y : lo.y, z ? hi.z : lo.z);
    };
    if (faces & 1) quad(p(0, 0, 0), p(0, 0, 1), p(0, 1, 1), p(0, 1, 0), -X, Z, Y, tile);
    if (faces & 2) quad(p(1, 0, 0), p(1, 0, 1), p(1, 1, 1), p(1, 1, 0), X, Z, Y, tile);
    if (faces & 4) quad(p(0, 0, 0), p(1, 0, 0), p(1, 0, 1), p(0, 0, 1), -Y, X, Z, tile);
    if (faces & 8) quad(p(0, 1, 0), p(1, 1, 0), p(1, 1, 1), p(0, 1, 1), Y, X, Z, tile);
    if (faces & 16) quad(p(0, 0, 0), p(1, 0, 0), p(1, 1, 0), p(0, 1, 0), -Z, X, Y, tile);
    if (faces & 32) quad(p(0, 0, 1), p(1, 0, 1), p(1, 1, 1), p(0, 1, 1), Z, X, Y, tile);
  }

  // Tangents and bounds filled in.
  Mesh finish(std::string name, uint32_t material) {
    Mesh m = std::move(mesh_);
    mesh_ = Mesh{};
    m.name = std::move(name);
    m.material = material;
    computeTangents(m);
    updateBounds(m);
    return m;
  }

 private:
  Mesh mesh_;
};

}  // namespace tally::scenes
