// The per-draw passes' material (forward.frag, gbuffer.frag): the draw's
// five maps bound in set 1 (a neutral 1x1 dummy where missing; each with
// its texture's own sampler), sampled at each map's uv (uv set and texture
// transform, material_features.h), the vertex colour, the alpha test of
// alphaMode MASK and the emission. One body, so both renderers read the
// same maps the same way.
#ifndef TALLY_SHADERS_DRAW_MATERIAL_H
#define TALLY_SHADERS_DRAW_MATERIAL_H
#include "draw_uv.h"

layout(set = kSetMaterial, binding = kMapDiffuse) uniform sampler2D diffuseMap;
layout(set = kSetMaterial, binding = kMapAmbient) uniform sampler2D ambientMap;
layout(set = kSetMaterial, binding = kMapSpecular) uniform sampler2D specularMap;
layout(set = kSetMaterial, binding = kMapRoughness) uniform sampler2D roughnessMap;
layout(set = kSetMaterial, binding = kMapNormal) uniform sampler2D normalMap;
#ifdef TALLY_EMISSIVE_MAPS
layout(set = kSetMaterial, binding = kBindingEmissiveMap) uniform sampler2D emissiveMap;
#endif

layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = 1) in vec3 inNormal;
layout(location = 2) in vec4 inTangent;
layout(location = 3) in vec2 inUv;
#ifdef TALLY_VERTEX_COLORS
layout(location = 4) in vec4 inColor;  // COLOR_0
#endif
#ifdef TALLY_UV1
layout(location = 5) in vec2 inUv1;  // TEXCOORD_1
#endif

struct DrawMaterial {
  Surface surface;
  float alpha;    // diffuse alpha x base colour alpha (x vertex colour alpha)
  vec3 emission;  // added to the shaded colour
};

DrawMaterial drawMaterial() {
  uint m = push.materialIndex;
#ifdef TALLY_UV1
  vec2 uv1 = inUv1;
#else
  vec2 uv1 = inUv;
#endif
  vec4 baseColor = materials[m].baseColor;
#ifdef TALLY_VERTEX_COLORS
  baseColor *= inColor;
#endif
  UvFrame f = uvFrame(inUv, uv1);  // derivatives before anything is loaded
  vec4 diffuse = SAMPLE_DRAW_MAP(diffuseMap, m, kMapDiffuse, f);
  DrawMaterial d;
  d.alpha = diffuse.a * baseColor.a;
#ifdef TALLY_ALPHA_TEST
  if (d.alpha < materialExtras[m].alphaCutoff) discard;  // before the other maps are read
#endif
  d.surface = surfaceFromMaps(diffuse, SAMPLE_DRAW_MAP(ambientMap, m, kMapAmbient, f),
                              SAMPLE_DRAW_MAP(specularMap, m, kMapSpecular, f),
                              SAMPLE_DRAW_MAP(roughnessMap, m, kMapRoughness, f),
                              SAMPLE_DRAW_MAP(normalMap, m, kMapNormal, f), inNormal, inTangent, baseColor,
                              materials[m].roughnessFactor);
#ifdef TALLY_EMISSIVE_MAPS
  d.emission = emissionOf(m, SAMPLE_DRAW_MAP(emissiveMap, m, kMapEmissive, f));
#else
  d.emission = emissionOf(m, vec4(1.0));
#endif
  return d;
}

#endif  // TALLY_SHADERS_DRAW_MATERIAL_H
