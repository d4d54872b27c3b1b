// The analytic scenes: planes and sky. Both are seen by one fixed head-on
// camera at the origin looking down -Z, and every quad is sized from the
// camera's field of view so its projection is known exactly:
// - vertically it spans exactly the wanted fraction of the screen height,
//   because a quad at distance d perpendicular to the view direction projects
//   to NDC y = y_world / (d * tan(fov / 2)) with no approximation;
// - horizontally it spans the whole width of any view with aspect up to
//   kMaxAnalyticAspect, so the covered fraction of the screen AREA equals the
//   covered fraction of its HEIGHT whatever the resolution's aspect.
// What is left inexact is rasterization: a pixel is covered when its centre
// is, so a quad covers round(coverage * height) rows give or take one row.
#include <cmath>

#include "scenes/mesh_builder.hpp"
#include "scenes/procedural.hpp"
#include "scenes/textures.hpp"

namespace tally::scenes {

const char* toString(DrawOrder order) {
  return order == DrawOrder::BackToFront ? "back-to-front" : "front-to-back";
}

namespace {

constexpr float kFovDeg = 60.0f;             // the fixed camera's vertical field of view
constexpr float kNearestPlane = 2.0f;        // metres from the eye to the nearest quad
constexpr float kPlaneSpacing = 0.1f;        // metres between layers: 1024 layers end at ~104 m,
                                             // still ~15 D32 depth steps apart with a 0.1 m near plane
constexpr float kSkyDistance = 4.0f;         // metres from the eye to the sky scene's quad
constexpr float kUvRepeatsPerScreen = 4.0f;  // 4 x 256 texels per screen height: ~1 texel per pixel at 1080p

Camera fixedCamera(float skyFraction) {
  Camera c;
  c.eye = glm::vec3(0.0f);
  c.target = glm::vec3(0.0f, 0.0f, -1.0f);
  c.fovDeg = kFovDeg;
  c.skyFraction = skyFraction;
  c.label = "fixed head-on";
  return c;
}

// Quad at z = -d spanning NDC x in [-kMaxAnalyticAspect, +kMaxAnalyticAspect]
// (in units of the screen height) and NDC y in [yLo, yHi], facing the camera.
// UVs follow the screen, so every layer samples the same texels per pixel.
Mesh screenQuad(float d, float yLo, float yHi, uint32_t material, std::string name) {
  const float s = d * std::tan(glm::radians(kFovDeg) * 0.5f);  // world units per NDC unit at depth d
  const float w = kMaxAnalyticAspect * s;
  const glm::vec3 n(0.0f, 0.0f, 1.0f);
  MeshBuilder b;
  auto v = [&](float x, float y) {
    glm::vec2 uv = glm::vec2(x / s, -y / s) * (0.5f * kUvRepeatsPerScreen);
    return b.vertex(glm::vec3(x, y, -d), n, uv);
  };
  uint32_t i0 = v(-w, yLo * s), i1 = v(w, yLo * s), i2 = v(w, yHi * s), i3 = v(-w, yHi * s);
  b.triangle(i0, i1, i2, n);
  b.triangle(i0, i2, i3, n);
  return b.finish(std::move(name), material);
}

}  // namespace

// planes: overdraw and early-z. 2 triangles per layer (the fewest that make a
// rectangle), one mesh (draw) per layer so the mesh order is the draw order:
// back-to-front makes every layer pass the depth test (layers x covered pixels
// shaded), front-to-back lets early-z reject all but the first. One material,
// all five maps, so per-pixel texture reads are the same everywhere.
Scene makePlanes(const PlanesParams& params) {
  Scene scene;
  scene.name = "planes";
  uint32_t material = addProceduralMaterial(scene, ProceduralMaterial::Tiles);
  for (int k = 0; k < params.layers; ++k) {
    int depthIndex = params.order == DrawOrder::FrontToBack ? k : params.layers - 1 - k;  // 0 = nearest
    float d = kNearestPlane + kPlaneSpacing * float(depthIndex);
    scene.meshes.push_back(screenQuad(d, -float(params.coverage), float(params.coverage), material,
                                      "plane " + std::to_string(depthIndex) + " (depth order)"));
  }
  updateBounds(scene);
  scene.fixedCameras.push_back(fixedCamera(float(1.0 - params.coverage)));
  scene.params = {{"name", "planes"},
                  {"layers", params.layers},
                  {"order", toString(params.order)},
                  {"coverage", params.coverage}};
  return scene;
}

// sky: the stencil sky mask. One quad (2 triangles) covers the bottom
// `coverage` of the screen; its lower edge lies below the view so coverage 0
// still gives a proper (off-screen) quad.
Scene makeSky(const SkyParams& params) {
  Scene scene;
  scene.name = "sky";
  uint32_t material = addProceduralMaterial(scene, ProceduralMaterial::Stone);
  scene.meshes.push_back(
      screenQuad(kSkyDistance, -1.5f, float(-1.0 + 2.0 * params.coverage), material, "ground"));
  updateBounds(scene);
  scene.fixedCameras.push_back(fixedCamera(float(1.0 - params.coverage)));
  scene.params = {{"name", "sky"}, {"coverage", params.coverage}};
  return scene;
}

}  // namespace tally::scenes
