// glTF material features (scenes::Scene::Features), GLSL only, included by
// common.h. Each part is compiled in only under its define (GpuScene::
// featureDefines()), so the founding study's scenes keep their shaders and
// counts; every read here is counted like the rest.
//   TALLY_VERTEX_COLORS  COLOR_0 multiplies the base colour (and its alpha)
//   TALLY_UV1            a map samples TEXCOORD_1 (MaterialExtra::texCoords)
//   TALLY_UV_TRANSFORM   KHR_texture_transform per map
//   TALLY_EMISSIVE       emissiveFactor added to the shaded colour
//   TALLY_EMISSIVE_MAPS  ... times the emissive map
//   TALLY_WRAP_EMULATION map arrays only: non-repeating wraps done here
//   TALLY_ALPHA_TEST     alphaMode MASK pipelines: discard below the cutoff
//   TALLY_TRANSPARENT    alphaMode BLEND: the transparent pass
#ifndef TALLY_SHADERS_MATERIAL_FEATURES_H
#define TALLY_SHADERS_MATERIAL_FEATURES_H

#if defined(TALLY_UV1) || defined(TALLY_UV_TRANSFORM) || defined(TALLY_EMISSIVE) || \
    defined(TALLY_WRAP_EMULATION) || defined(TALLY_ALPHA_TEST) || defined(TALLY_TRANSPARENT)
#define TALLY_MATERIAL_EXTRAS
layout(std430, set = kSetGeometry, binding = kBindingMaterialExtras) readonly buffer MaterialExtraBuffer {
  MaterialExtra materialExtras[];
};
#endif

// The uv map k of `material` samples: its uv set, then its texture transform.
vec2 mapUv(uint material, uint k, vec2 uv0, vec2 uv1) {
  vec2 uv = uv0;
#ifdef TALLY_UV1
  if ((materialExtras[material].texCoords & (1u << k)) != 0u) uv = uv1;
#endif
#ifdef TALLY_UV_TRANSFORM
  vec3 h = vec3(uv, 1.0);
  uv = vec2(dot(materialExtras[material].uvTransform[2u * k].xyz, h),
            dot(materialExtras[material].uvTransform[2u * k + 1u].xyz, h));
#endif
  return uv;
}

// The change of map k's uv for a change `d` of its source uv (the transform's
// linear part): derivatives for textureGrad.
vec2 mapUvDelta(uint material, uint k, vec2 d) {
#ifdef TALLY_UV_TRANSFORM
  return vec2(dot(materialExtras[material].uvTransform[2u * k].xy, d),
              dot(materialExtras[material].uvTransform[2u * k + 1u].xy, d));
#else
  return d;
#endif
}

// True when map k of `material` samples TEXCOORD_1.
bool mapUsesUv1(uint material, uint k) {
#ifdef TALLY_UV1
  return (materialExtras[material].texCoords & (1u << k)) != 0u;
#else
  return false;
#endif
}

// Map arrays share one repeating sampler per kind: a map whose sampler
// mirrors or clamps gets its uv folded here, then kept half a texel (of
// level 0, `size` texels) inside the edge so the repeating sampler's
// bilinear taps do not reach across it. Exact at level 0; coarser levels
// still blend within half of their texel at the edge.
vec2 wrapUv(uint material, uint k, vec2 uv, vec2 size) {
#ifdef TALLY_WRAP_EMULATION
  uint bits = (materialExtras[material].wraps >> (4u * k)) & 15u;
  for (int axis = 0; axis < 2; ++axis) {
    uint mode = (bits >> (2u * uint(axis))) & 3u;
    float t = uv[axis], edge = 0.5 / size[axis];
    if (mode == 1u) t = clamp(1.0 - abs(mod(t, 2.0) - 1.0), edge, 1.0 - edge);  // mirrored repeat
    if (mode == 2u) t = clamp(t, edge, 1.0 - edge);                            // clamp to edge
    uv[axis] = t;
  }
#endif
  return uv;
}

// Emission of `material`: its factor times the emissive texel (white without a map).
vec3 emissionOf(uint material, vec4 emissiveTexel) {
#ifdef TALLY_EMISSIVE
  return materialExtras[material].emissive.rgb * emissiveTexel.rgb;
#else
  return vec3(0.0);
#endif
}

#ifdef TALLY_VERTEX_COLORS
// VertexAttributes::color (RGBA16 unorm in two uints) as RGBA.
vec4 unpackVertexColor(uint c[2]) { return vec4(unpackUnorm2x16(c[0]), unpackUnorm2x16(c[1])); }
#endif

#endif  // TALLY_SHADERS_MATERIAL_FEATURES_H
