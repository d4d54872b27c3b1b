// The projection and the camera uniform (shaders/shared.h Camera) every
// renderer uploads, built in one place so that code reproducing a shader's
// math on the CPU (the depth-reconstruction sweep) uses the very matrices the
// GPU saw. Depth convention: [0, 1], far = 1, finite far plane, not reversed.
#pragma once

#include <vulkan/vulkan.h>

#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"
#include "shared.h"

namespace tally::renderers {

// Perspective for Vulkan: depth [0, 1] with far = 1, y flipped (positive-height
// viewport), vertical field of view (scene.hpp).
glm::mat4 perspective(float fovYRad, float aspect, float zNear, float zFar);

// Near/far from the scene bounds, so the far plane lies beyond every triangle
// (the CPU sky estimate assumes unbounded rays) and the near plane scales
// with the scene: diagonal / 1000 within [min(1 cm, diagonal / 200), 10 cm].
DepthRange depthRangeFor(const scenes::Bounds& bounds, const scenes::Camera& camera);

shaders::Camera cameraUniform(const scenes::Camera& camera, VkExtent2D extent, DepthRange range);

}  // namespace tally::renderers
