// Visibility-buffer shading shared by the fragment (shading.frag,
// shading_lean.frag) and compute (shading.comp, shading_lean.comp) passes,
// so that shading=fragment and shading=compute run the same math: the
// material maps (descriptor indexing or map arrays, the material selection)
// and shadeTriangle(). Every map read is a textureGrad with derivatives the
// shading computes itself (stored by the fat visibility pass, analytic in the
// lean one): nothing here needs implicit derivatives, which compute lacks.
// Define before #include: TALLY_SHADE_FAT (needs visibility_encoding.h) or
// TALLY_SHADE_LEAN.
#ifndef TALLY_SHADERS_VISBUFFER_SHADE_H
#define TALLY_SHADERS_VISBUFFER_SHADE_H

// See shading.frag: non-uniform indexing, or map arrays (TALLY_MAP_ARRAYS).
// Material selection (RendererOptions::materialSelection), defined by the
// renderer; by default the per-pixel selection above. TALLY_SELECT_UNIFORM:
// the index without nonuniformEXT, as the founding study wrote it (undefined
// unless dynamically uniform: what the driver does is what is measured).
// TALLY_SELECT_FIRST_LANE: every lane takes the first active lane's index or
// layer, a model of a driver that scalarises the index.
#ifdef TALLY_SELECT_FIRST_LANE
#extension GL_KHR_shader_subgroup_ballot : require
#endif
#ifdef TALLY_MAP_ARRAYS
// Fallback without descriptor indexing (lavapipe), defined by the renderer:
// one sampler2DArray per map kind, Material::maps[k] is the layer. The
// selection stays per pixel and needs no non-uniform descriptor index.
layout(set = kSetMaterial, binding = kMapDiffuse) uniform sampler2DArray diffuseMaps;
layout(set = kSetMaterial, binding = kMapAmbient) uniform sampler2DArray ambientMaps;
layout(set = kSetMaterial, binding = kMapSpecular) uniform sampler2DArray specularMaps;
layout(set = kSetMaterial, binding = kMapRoughness) uniform sampler2DArray roughnessMaps;
layout(set = kSetMaterial, binding = kMapNormal) uniform sampler2DArray normalMaps;
#ifdef TALLY_SELECT_FIRST_LANE
#define SAMPLE_MAP(kindMaps, kind) textureGrad(kindMaps, vec3(a.uv, float(subgroupBroadcastFirst(maps[kind]))), dx, dy)
#else
#define SAMPLE_MAP(kindMaps, kind) textureGrad(kindMaps, vec3(a.uv, float(maps[kind])), dx, dy)
#endif
#else
layout(set = kSetMaterial, binding = kBindingMaterialMaps) uniform sampler2D materialMaps[kMaxMaterialMaps];
#if defined(TALLY_SELECT_FIRST_LANE)
#define SAMPLE_MAP(kindMaps, kind) textureGrad(materialMaps[subgroupBroadcastFirst(maps[kind])], a.uv, dx, dy)
#elif defined(TALLY_SELECT_UNIFORM)
#define SAMPLE_MAP(kindMaps, kind) textureGrad(materialMaps[maps[kind]], a.uv, dx, dy)
#else
#define SAMPLE_MAP(kindMaps, kind) textureGrad(materialMaps[nonuniformEXT(maps[kind])], a.uv, dx, dy)
#endif
#endif

// Both buffers: the material's five maps sampled at the interpolated uv with
// the uv derivatives dx, dy (SAMPLE_MAP above), then every light.
vec3 shadeInterpolated(uint material, Interpolated a, vec2 dx, vec2 dy) {
  uint maps[kMapCount] = materials[material].maps;
  Surface s = surfaceFromMaps(SAMPLE_MAP(diffuseMaps, kMapDiffuse),
                              SAMPLE_MAP(ambientMaps, kMapAmbient),
                              SAMPLE_MAP(specularMaps, kMapSpecular),
                              SAMPLE_MAP(roughnessMaps, kMapRoughness),
                              SAMPLE_MAP(normalMaps, kMapNormal),
                              a.normal, a.tangent, materials[material].baseColor,
                              materials[material].roughnessFactor);
  return shade(s, a.position);
}

#ifdef TALLY_SHADE_FAT
// The fat visibility texel's triangle: barycentrics and uv derivatives as stored.
vec3 shadeTriangle(uvec4 visibility, uvec4 uvDerivatives) {
  uint drawId = visibilityDrawId(visibility.x);
  vec2 b12 = decodeBarycentrics(visibility);

  uvec3 v = fetchTriangle(draws[drawId].firstIndex, draws[drawId].vertexOffset,
                          visibilityTriangleId(visibility.x));
  Interpolated a = interpolateVertices(vertices[v.x], vertices[v.y], vertices[v.z],
                                       vec3(1.0 - b12.x - b12.y, b12), draws[drawId].model);
  vec2 dx, dy;
  decodeUvDerivatives(uvDerivatives, dx, dy);
  return shadeInterpolated(draws[drawId].materialIndex, a, dx, dy);
}
#endif

#ifdef TALLY_SHADE_LEAN
// The lean id's triangle at `fragCoord` (a pixel centre): barycentrics and
// their change across one pixel from the re-projected vertices.
vec3 shadeTriangle(uint id, vec2 fragCoord) {
  uint drawId = visibilityDrawId(id);
  mat4 model = draws[drawId].model;
  uvec3 v = fetchTriangle(draws[drawId].firstIndex, draws[drawId].vertexOffset, visibilityTriangleId(id));
  TALLY_VERTEX v0 = vertices[v.x], v1 = vertices[v.y], v2 = vertices[v.z];

  mat4 clipFromObject = camera.viewProj * model;
  Barycentrics b = barycentricsFromClip(clipFromObject * vec4(toVec3(v0.position), 1.0),
                                        clipFromObject * vec4(toVec3(v1.position), 1.0),
                                        clipFromObject * vec4(toVec3(v2.position), 1.0), fragCoord);
  Interpolated a = interpolateVertices(v0, v1, v2, b.lambda, model);
  mat3x2 uvs = mat3x2(uvOf(v0), uvOf(v1), uvOf(v2));
  vec2 dx = uvs * b.ddx, dy = uvs * b.ddy;

  return shadeInterpolated(draws[drawId].materialIndex, a, dx, dy);
}
#endif

#endif  // TALLY_SHADERS_VISBUFFER_SHADE_H
