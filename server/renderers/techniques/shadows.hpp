// Shadow mapping (docs/techniques.md, "Shadow mapping"): one directional sun
// with an orthographic projection fitted to the scene bounds. RendererBase
// adds a depth-only "shadow" pass before the renderer's own passes into the
// D32_SFLOAT "shadow_map" (size x size) and binds the map and the sun's
// uniform in set 0, read by shade() (shaders/shadow.h) in every shading pass.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "gpu/resources.hpp"
#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"
#include "shadow_shared.h"

namespace tally::renderers {

std::string_view toString(ShadowFilter filter);  // "off", "hard", "pcf2x2", "pcf4x4"
std::optional<ShadowFilter> parseShadowFilter(std::string_view name);  // empty for an unknown name

// Depth-compare taps per shaded pixel (shadow.h): hard and pcf2x2 one (the
// sampler's filter differs), pcf4x4 four linear taps; 0 with shadows off.
uint32_t shadowTapsPerPixel(ShadowFilter filter);

constexpr float kSunRadiance = 2.0f;  // the sun's colour, white

// The sun's uniform for `bounds`: the light looks along -direction; the
// orthographic box is the light-space AABB of the bounds' 8 corners (padded
// 1%), so every receiver lies in the map and in depth [0, 1].
shaders::Shadow shadowUniform(const scenes::Bounds& bounds, const ShadowOptions& options);

// What RendererBase keeps for the shadow pass (empty with shadows off).
struct ShadowState {
  gpu::Image map;                          // "shadow_map", D32_SFLOAT, size x size
  gpu::Buffer uniform;                     // "shadow", shaders::Shadow
  VkSampler sampler = VK_NULL_HANDLE;      // compare LESS_OR_EQUAL, nearest (hard) or linear
  nlohmann::json extras;                   // frameExtras()["shadows"]
};

}  // namespace tally::renderers
