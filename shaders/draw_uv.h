// Fragment stages of the per-draw passes only (draw_material.h,
// alpha_test.h): they need implicit derivatives.
#ifndef TALLY_SHADERS_DRAW_UV_H
#define TALLY_SHADERS_DRAW_UV_H

// Per-draw passes (implicit derivatives): a map read at its uv with the
// derivatives of its source uv taken from the varyings, then transformed.
// No derivative may cross a value loaded from memory: llvmpipe gives helper
// lanes zeros for buffer loads, so texture(map, mapUv(...)) there picks the
// smallest mip at every quad with a helper lane. Without uv features it is
// the plain texture() the founding study's shaders use.
struct UvFrame {
  vec2 uv0, uv1, dx0, dy0, dx1, dy1;
};
UvFrame uvFrame(vec2 uv0, vec2 uv1) { return UvFrame(uv0, uv1, dFdx(uv0), dFdy(uv0), dFdx(uv1), dFdy(uv1)); }
#if defined(TALLY_UV1) || defined(TALLY_UV_TRANSFORM)
#define SAMPLE_DRAW_MAP(map, material, k, f)                                                       \
  textureGrad(map, mapUv(material, k, f.uv0, f.uv1),                                               \
              mapUvDelta(material, k, mapUsesUv1(material, k) ? f.dx1 : f.dx0),                     \
              mapUvDelta(material, k, mapUsesUv1(material, k) ? f.dy1 : f.dy0))
#else
#define SAMPLE_DRAW_MAP(map, material, k, f) texture(map, f.uv0)
#endif

#endif  // TALLY_SHADERS_DRAW_UV_H
