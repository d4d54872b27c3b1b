// What the fat visibility buffer stores per pixel, one definition for the two
// visibility fragment shaders (writers) and the shading pass (reader). The
// renderer chooses with defines (RendererOptions::visibility) and sizes the
// targets to match (renderers/visbuffer.cpp):
//   id target, default:        R32G32_UINT (id, packUnorm2x16(b1, b2)): steps of 1/65535
//   TALLY_BARYCENTRICS_FLOAT32: R32G32B32_UINT (id, float bits of b1, b2), or
//                               R32G32B32A32_UINT where the device cannot render to RGB32
//   derivative target, default: R32G32_UINT (packHalf2x16(dFdx(uv)), packHalf2x16(dFdy(uv))):
//                               11 significant bits
//   TALLY_UV_DERIVATIVES_UNORM16: R32G32_UINT (packUnorm2x16 of each), the founding
//                               study's packing: components clamped to [0, 1], so
//                               negative ones become 0, then steps of 1/65535
//   TALLY_UV_DERIVATIVES_FLOAT32: R32G32B32A32_UINT (float bits of dFdx(uv), dFdy(uv))
// b0 = 1 - b1 - b2 is never stored.
#ifndef TALLY_SHADERS_VISIBILITY_ENCODING_H
#define TALLY_SHADERS_VISIBILITY_ENCODING_H

#ifdef TALLY_BARYCENTRICS_FLOAT32
#define VisibilityTexel uvec4
VisibilityTexel encodeVisibility(uint id, vec2 b12) { return uvec4(id, floatBitsToUint(b12), 0u); }
vec2 decodeBarycentrics(uvec4 texel) { return uintBitsToFloat(texel.yz); }
#else
#define VisibilityTexel uvec2
VisibilityTexel encodeVisibility(uint id, vec2 b12) { return uvec2(id, packUnorm2x16(b12)); }
vec2 decodeBarycentrics(uvec4 texel) { return unpackUnorm2x16(texel.y); }
#endif

#if defined(TALLY_UV_DERIVATIVES_FLOAT32)
#define UvDerivativeTexel uvec4
UvDerivativeTexel encodeUvDerivatives(vec2 dx, vec2 dy) { return floatBitsToUint(vec4(dx, dy)); }
void decodeUvDerivatives(uvec4 texel, out vec2 dx, out vec2 dy) {
  dx = uintBitsToFloat(texel.xy);
  dy = uintBitsToFloat(texel.zw);
}
#elif defined(TALLY_UV_DERIVATIVES_UNORM16)
#define UvDerivativeTexel uvec2
UvDerivativeTexel encodeUvDerivatives(vec2 dx, vec2 dy) { return uvec2(packUnorm2x16(dx), packUnorm2x16(dy)); }
void decodeUvDerivatives(uvec4 texel, out vec2 dx, out vec2 dy) {
  dx = unpackUnorm2x16(texel.x);
  dy = unpackUnorm2x16(texel.y);
}
#else
#define UvDerivativeTexel uvec2
UvDerivativeTexel encodeUvDerivatives(vec2 dx, vec2 dy) { return uvec2(packHalf2x16(dx), packHalf2x16(dy)); }
void decodeUvDerivatives(uvec4 texel, out vec2 dx, out vec2 dy) {
  dx = unpackHalf2x16(texel.x);
  dy = unpackHalf2x16(texel.y);
}
#endif

#endif  // TALLY_SHADERS_VISIBILITY_ENCODING_H
