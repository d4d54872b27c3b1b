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
// The index or layer a pixel's map is read from, by the material selection.
#if defined(TALLY_SELECT_FIRST_LANE)
#define SELECT_MAP(index) subgroupBroadcastFirst(index)
#elif defined(TALLY_SELECT_UNIFORM) || defined(TALLY_MAP_ARRAYS)
#define SELECT_MAP(index) (index)
#else
#define SELECT_MAP(index) nonuniformEXT(index)
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
#ifdef TALLY_EMISSIVE_MAPS
layout(set = kSetMaterial, binding = kBindingEmissiveMap) uniform sampler2DArray emissiveMaps;
#endif
#define SAMPLE_LAYER(kindMaps, index, c) textureGrad(kindMaps, vec3(c.uv, float(SELECT_MAP(index))), c.dx, c.dy)
#define SAMPLE_MAP(kindMaps, kind, c) SAMPLE_LAYER(kindMaps, maps[kind], c)
#define SAMPLE_EMISSIVE(index, c) SAMPLE_LAYER(emissiveMaps, index, c)
#define MAP_SIZE(kindMaps) vec2(textureSize(kindMaps, 0).xy)  // an image query: not counted
#else
layout(set = kSetMaterial, binding = kBindingMaterialMaps) uniform sampler2D materialMaps[kMaxMaterialMaps];
#define SAMPLE_INDEX(index, c) textureGrad(materialMaps[SELECT_MAP(index)], c.uv, c.dx, c.dy)
#define SAMPLE_MAP(kindMaps, kind, c) SAMPLE_INDEX(maps[kind], c)
#define SAMPLE_EMISSIVE(index, c) SAMPLE_INDEX(index, c)
#define MAP_SIZE(kindMaps) vec2(1.0)  // each texture has its own sampler: no wrap to emulate
#endif

// glTF's optional vertex streams at the pixel (white and TEXCOORD_0 without
// them), with the second uv set's change across one pixel.
struct ExtraAttributes {
  vec4 color;
  vec2 uv1, dx1, dy1;
};

// Where map k of `material` is read: its uv (set, transform; folded by the
// wrap on map arrays) and the uv's change across one pixel in x and y.
struct MapCoords {
  vec2 uv, dx, dy;
};
// `size`: the map array's level-0 texels (map arrays), for the wrap.
MapCoords mapCoords(uint material, uint k, vec2 uv0, vec2 dx, vec2 dy, ExtraAttributes e, vec2 size) {
  MapCoords c;
  bool second = mapUsesUv1(material, k);
  c.uv = mapUv(material, k, uv0, e.uv1);
  c.dx = mapUvDelta(material, k, second ? e.dx1 : dx);
  c.dy = mapUvDelta(material, k, second ? e.dy1 : dy);
#ifdef TALLY_MAP_ARRAYS
  c.uv = wrapUv(material, k, c.uv, size);
#endif
  return c;
}

// Both buffers: the material's five maps sampled at their uvs with their
// derivatives (SAMPLE_MAP above), then every light, then the emission.
vec3 shadeInterpolated(uint material, Interpolated a, vec2 dx, vec2 dy, ExtraAttributes e) {
  uint maps[kMapCount] = materials[material].maps;
  MapCoords cDiffuse = mapCoords(material, kMapDiffuse, a.uv, dx, dy, e, MAP_SIZE(diffuseMaps));
  MapCoords cAmbient = mapCoords(material, kMapAmbient, a.uv, dx, dy, e, MAP_SIZE(ambientMaps));
  MapCoords cSpecular = mapCoords(material, kMapSpecular, a.uv, dx, dy, e, MAP_SIZE(specularMaps));
  MapCoords cRoughness = mapCoords(material, kMapRoughness, a.uv, dx, dy, e, MAP_SIZE(roughnessMaps));
  MapCoords cNormal = mapCoords(material, kMapNormal, a.uv, dx, dy, e, MAP_SIZE(normalMaps));
  Surface s = surfaceFromMaps(SAMPLE_MAP(diffuseMaps, kMapDiffuse, cDiffuse),
                              SAMPLE_MAP(ambientMaps, kMapAmbient, cAmbient),
                              SAMPLE_MAP(specularMaps, kMapSpecular, cSpecular),
                              SAMPLE_MAP(roughnessMaps, kMapRoughness, cRoughness),
                              SAMPLE_MAP(normalMaps, kMapNormal, cNormal),
                              a.normal, a.tangent, materials[material].baseColor * e.color,
                              materials[material].roughnessFactor);
  vec3 color = shade(s, a.position);
#ifdef TALLY_EMISSIVE_MAPS
  MapCoords cEmissive = mapCoords(material, kMapEmissive, a.uv, dx, dy, e, MAP_SIZE(emissiveMaps));
  color += emissionOf(material, SAMPLE_EMISSIVE(materialExtras[material].emissiveMap, cEmissive));
#elif defined(TALLY_EMISSIVE)
  color += emissionOf(material, vec4(1.0));
#endif
  return color;
}

// The triangle's streams at barycentrics `lambda`. The second uv set's
// derivatives: from barycentric derivatives where known (lean), else from
// the first set's (fat): within a triangle both sets are affine in the
// barycentrics, so d(uv1) = E1 E0^-1 d(uv0) with E the edge matrices.
ExtraAttributes extraAttributes(uvec3 v, vec3 lambda, vec3 ddx, vec3 ddy, bool fromBarycentrics, vec2 dx, vec2 dy) {
  ExtraAttributes e;
  e.color = vec4(1.0);
  e.uv1 = vec2(0.0);
  e.dx1 = dx;
  e.dy1 = dy;
#ifdef TALLY_VERTEX_COLORS
  e.color = mat3x4(unpackVertexColor(vertexAttributes[v.x].color), unpackVertexColor(vertexAttributes[v.y].color),
                   unpackVertexColor(vertexAttributes[v.z].color)) * lambda;
#endif
#ifdef TALLY_UV1
  mat3x2 uvs1 = mat3x2(vec2(vertexAttributes[v.x].uv1[0], vertexAttributes[v.x].uv1[1]),
                       vec2(vertexAttributes[v.y].uv1[0], vertexAttributes[v.y].uv1[1]),
                       vec2(vertexAttributes[v.z].uv1[0], vertexAttributes[v.z].uv1[1]));
  e.uv1 = uvs1 * lambda;
  if (fromBarycentrics) {
    e.dx1 = uvs1 * ddx;
    e.dy1 = uvs1 * ddy;
  } else {
    vec2 t0 = uvOf(vertices[v.x]), t1 = uvOf(vertices[v.y]), t2 = uvOf(vertices[v.z]);
    mat2 e0 = mat2(t1 - t0, t2 - t0), e1 = mat2(uvs1[1] - uvs1[0], uvs1[2] - uvs1[0]);
    float det = determinant(e0);
    mat2 toUv1 = abs(det) > 1e-20 ? e1 * inverse(e0) : mat2(0.0);  // degenerate uv0: level 0
    e.dx1 = toUv1 * dx;
    e.dy1 = toUv1 * dy;
  }
#endif
  return e;
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
  ExtraAttributes e = extraAttributes(v, vec3(1.0 - b12.x - b12.y, b12), vec3(0.0), vec3(0.0), false, dx, dy);
  return shadeInterpolated(draws[drawId].materialIndex, a, dx, dy, e);
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
  ExtraAttributes e = extraAttributes(v, b.lambda, b.ddx, b.ddy, true, dx, dy);
  return shadeInterpolated(draws[drawId].materialIndex, a, dx, dy, e);
}
#endif

#endif  // TALLY_SHADERS_VISBUFFER_SHADE_H
