#include "sweeps/precision.hpp"

#include <algorithm>
#include <cmath>

#include "scenes/mesh_builder.hpp"
#include "scenes/textures.hpp"
#include "sweeps/precision_plane.hpp"

namespace tally::sweeps {
namespace {

using precision_plane::Grid;
using precision_plane::gridOf;
using precision_plane::Plane;
using precision_plane::planeAt;
using precision_plane::tooManyTriangles;
using precision_plane::UvMap;
using precision_plane::uvMapOf;
using precision_plane::View;
using precision_plane::viewOf;

}  // namespace

scenes::Texture precisionTexture(uint32_t size) {
  // Saturated colours, each far from its neighbours in the cycle.
  static const glm::vec3 kLevelColours[] = {{1.0f, 0.16f, 0.16f}, {0.16f, 1.0f, 0.16f}, {0.25f, 0.25f, 1.0f},
                                            {1.0f, 1.0f, 0.16f},  {1.0f, 0.16f, 1.0f},  {0.16f, 1.0f, 1.0f},
                                            {1.0f, 0.6f, 0.16f}};
  constexpr uint32_t kColours = sizeof kLevelColours / sizeof kLevelColours[0];
  auto level = [&](uint32_t l) {
    const uint32_t n = std::max(size >> l, 1u);
    std::vector<uint8_t> texels(size_t(n) * n * 4);
    for (uint32_t y = 0; y < n; ++y) {
      for (uint32_t x = 0; x < n; ++x) {
        const float checker = ((x + y) & 1u) ? 1.0f : 0.35f;
        const float jitter = 0.9f + 0.2f * float(scenes::texelHash(x, y, l) >> 8) * (1.0f / 16777216.0f);
        const glm::vec3 c = glm::clamp(kLevelColours[l % kColours] * checker * jitter, 0.0f, 1.0f);
        uint8_t* t = &texels[(size_t(y) * n + x) * 4];
        for (int i = 0; i < 3; ++i) t[i] = uint8_t(std::lround(c[i] * 255.0f));
        t[3] = 255;
      }
    }
    return texels;
  };
  scenes::Texture t;
  t.name = "precision/diffuse";
  t.width = t.height = size;
  t.srgb = true;
  t.rgba8 = level(0);
  for (uint32_t l = 1; (size >> l) > 0; ++l) t.mips.push_back(level(l));
  return t;
}

Result<scenes::Scene> precisionScene(const PrecisionSweepSpec& spec, double distance, double triangleSize,
                                     const std::string& field) {
  const View v = viewOf(spec);
  const Plane plane = planeAt(v, distance);
  const UvMap uv = uvMapOf(spec);
  const Grid grid = gridOf(v, distance, triangleSize);
  if (grid.triangles() > double(kMaxPrecisionTriangles)) {
    return tooManyTriangles(field, triangleSize, distance, grid.triangles());
  }
  scenes::Scene scene;
  scene.name = "precision-plane";
  scene.textures.push_back(precisionTexture(spec.textureSize));
  scenes::Material material;
  material.name = "precision";
  material.maps[size_t(scenes::MapSlot::Diffuse)] = 0;
  scene.materials.push_back(material);

  const glm::vec3 facing(-float(plane.a), -float(plane.b), 1.0f);
  const glm::vec3 normal = glm::normalize(facing);
  scenes::MeshBuilder b;
  const int64_t nx = int64_t(grid.i1 - grid.i0), ny = int64_t(grid.j1 - grid.j0);
  for (int64_t j = 0; j <= ny; ++j) {
    for (int64_t i = 0; i <= nx; ++i) {
      const double x = (grid.i0 + double(i)) * triangleSize, y = (grid.j0 + double(j)) * triangleSize;
      const glm::vec3 p(float(x), float(y), float(-plane.d + plane.a * x + plane.b * y));
      b.vertex(p, normal, glm::vec2(uv(glm::dvec2(x, y))));
    }
  }
  auto at = [&](int64_t i, int64_t j) { return uint32_t(j * (nx + 1) + i); };
  for (int64_t j = 0; j < ny; ++j) {
    for (int64_t i = 0; i < nx; ++i) {
      // Right angles at (i + 1, j) and (i, j + 1); legs along x and y.
      b.triangle(at(i, j), at(i + 1, j), at(i + 1, j + 1), facing);
      b.triangle(at(i, j), at(i + 1, j + 1), at(i, j + 1), facing);
    }
  }
  scene.meshes.push_back(b.finish("plane", 0));
  scenes::updateBounds(scene);
  return scene;
}

scenes::Camera precisionCamera(const PrecisionSweepSpec& spec) {
  scenes::Camera camera;
  camera.eye = glm::vec3(0.0f);
  camera.target = glm::vec3(0.0f, 0.0f, -1.0f);
  camera.fovDeg = float(spec.fovDeg);
  camera.label = "head-on";
  return camera;
}

}  // namespace tally::sweeps
