// Shadow mapping's uniform and bindings, shared by the GLSL (shadow.h,
// shadow.vert.glsl) and the C++ (renderers/techniques/shadows.cpp). Only included with
// shadows on, so that with shadows off every shader is what it was.
// Set 0 (frame) gains two bindings with shadows on:
#ifndef TALLY_SHADERS_SHADOW_SHARED_H
#define TALLY_SHADERS_SHADOW_SHARED_H

#ifdef __cplusplus
#include <cstdint>
#include <glm/glm.hpp>
namespace tally::shaders {
#define TALLY_SHADOW_CONST(type, name, value) inline constexpr type name = value
using ShadowMat4 = glm::mat4;
using ShadowVec4 = glm::vec4;
using ShadowUint = uint32_t;
#else
#define TALLY_SHADOW_CONST(type, name, value) const type name = value
#define ShadowMat4 mat4
#define ShadowVec4 vec4
#define ShadowUint uint
#endif

TALLY_SHADOW_CONST(ShadowUint, kBindingShadow, 3u);     // set 0: UBO Shadow
TALLY_SHADOW_CONST(ShadowUint, kBindingShadowMap, 4u);  // set 0: sampler2DShadow, D32_SFLOAT "shadow_map"

struct Shadow {           // std140 UBO; 112 bytes
  ShadowMat4 viewProj;    // world -> the sun's orthographic clip space: xy [-1, 1] over the map, depth [0, 1]
  ShadowVec4 direction;   // xyz: unit vector towards the sun (world); w unused
  ShadowVec4 color;       // rgb: the sun's radiance; a unused
  ShadowVec4 params;      // x: bias (texels); y: world size of one texel (m); z: depth range (m); w: map size
};

#ifdef __cplusplus
static_assert(sizeof(Shadow) == 112);
}  // namespace tally::shaders
#else
#undef ShadowMat4
#undef ShadowVec4
#undef ShadowUint
#endif
#undef TALLY_SHADOW_CONST
#endif  // TALLY_SHADERS_SHADOW_SHARED_H
