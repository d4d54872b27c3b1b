#include "renderers/projection.hpp"

#include <algorithm>
#include <cmath>

namespace tally::renderers {

glm::mat4 perspective(float fovYRad, float aspect, float zNear, float zFar) {
  float f = 1.0f / std::tan(fovYRad / 2);
  glm::mat4 p(0.0f);
  p[0][0] = f / aspect;
  p[1][1] = -f;
  p[2][2] = zFar / (zNear - zFar);
  p[2][3] = -1.0f;
  p[3][2] = zNear * zFar / (zNear - zFar);
  return p;
}

DepthRange depthRangeFor(const scenes::Bounds& bounds, const scenes::Camera& camera) {
  float diagonal = std::max(bounds.diagonal(), 1e-5f);
  // 1/1000 of the diagonal, at least 1 cm and at most 10 cm; a scene under
  // 2 m across (a 10 cm model) lowers the floor to 1/200 of its diagonal,
  // half the clearance auto cameras keep from surfaces (cameras.cpp), so no
  // near-plane holes there. Scenes of 2 m and more keep the 1 cm floor.
  float zNear = std::clamp(diagonal * 1e-3f, std::min(0.01f, diagonal * 5e-3f), 0.1f);
  float zFar = (glm::length(camera.eye - bounds.center()) + diagonal * 0.5f) * 1.01f + 1.0f;
  return {zNear, zFar};
}

shaders::Camera cameraUniform(const scenes::Camera& camera, VkExtent2D extent, DepthRange range) {
  shaders::Camera c = {};
  c.view = scenes::viewMatrix(camera);
  c.proj = perspective(glm::radians(camera.fovDeg), float(extent.width) / float(extent.height), range.zNear,
                       range.zFar);
  c.viewProj = c.proj * c.view;
  c.invViewProj = glm::inverse(c.viewProj);
  c.position = glm::vec4(camera.eye, 1.0f);
  c.viewport = glm::vec4(extent.width, extent.height, 1.0f / extent.width, 1.0f / extent.height);
  c.depthRange = glm::vec4(range.zNear, range.zFar, 0, 0);
  return c;
}

}  // namespace tally::renderers
