// Forward output=density (docs/techniques.md, "Mesh density"): the class of
// the fragment's triangle in screen space, and the lanes its 2x2 quad launched.
// Needs TALLY_DRAWS and TALLY_MESH (the triangle's vertices by gl_PrimitiveID)
// before common.h. The classes, as renderers/techniques/density.hpp classifies on the CPU:
// - sub-pixel: screen area < 1 px^2;
// - long-thin: area >= 1 px^2 but the smallest altitude (2 x area / longest
//   edge) < 1 px: a sliver narrower than a pixel;
// - normal: the rest, and triangles with a vertex in front of the near plane
//   (clip z < 0), whose projected shape is not the drawn one.
#ifndef TALLY_SHADERS_DENSITY_H
#define TALLY_SHADERS_DENSITY_H

const uint kDensityNormal = 0u;
const uint kDensitySubPixel = 1u;
const uint kDensityLongThin = 2u;

vec2 densityPixel(vec4 clip) { return (clip.xy / clip.w * 0.5 + 0.5) * camera.viewport.xy; }

uint densityClass(uint drawIndex, uint triangle) {
  uvec3 v = fetchTriangle(draws[drawIndex].firstIndex, draws[drawIndex].vertexOffset, triangle);
  mat4 m = camera.viewProj * draws[drawIndex].model;
  vec4 c0 = m * vec4(toVec3(vertices[v.x].position), 1.0);
  vec4 c1 = m * vec4(toVec3(vertices[v.y].position), 1.0);
  vec4 c2 = m * vec4(toVec3(vertices[v.z].position), 1.0);
  if (c0.z < 0.0 || c1.z < 0.0 || c2.z < 0.0) return kDensityNormal;
  vec2 p0 = densityPixel(c0), p1 = densityPixel(c1), p2 = densityPixel(c2);
  vec2 e0 = p1 - p0, e1 = p2 - p1, e2 = p0 - p2;
  float area = 0.5 * abs(e0.x * e2.y - e0.y * e2.x);
  if (area < 1.0) return kDensitySubPixel;
  float longest = sqrt(max(dot(e0, e0), max(dot(e1, e1), dot(e2, e2))));
  return 2.0 * area / longest < 1.0 ? kDensityLongThin : kDensityNormal;
}

// Pure hues (the C++ side tells the classes apart by the zero channels):
// sub-pixel red, long-thin green, normal blue, scaled by the shaded
// luminance so that the surfaces stay readable.
vec3 densityColor(uint cls, vec3 shaded) {
  float l = dot(shaded, vec3(0.2126, 0.7152, 0.0722));
  float k = 4.0 * (0.35 + 0.65 * l / (1.0 + l));
  vec3 hue = cls == kDensitySubPixel ? vec3(1.0, 0.0, 0.0) : cls == kDensityLongThin ? vec3(0.0, 1.0, 0.0)
                                                                                    : vec3(0.0, 0.0, 1.0);
  return hue * k;
}

#ifdef TALLY_DENSITY_QUADS
// 4 from the first live (non-helper) lane of each 2x2 quad, 0 from the others:
// summed over the target, the lanes the quads launched, helpers included
// (a quad is 4 lanes; helper lanes' outputs are discarded, so a live lane
// counts for them). Called first in main(), in uniform control flow.
// TALLY_DENSITY_HELPER_BY_MASK (not set by forward.cpp: on llvmpipe, which
// cannot compile gl_HelperInvocation, the mask did not mark helper lanes
// either): a helper lane is one with no covered sample.
float densityQuadLanes() {
#ifdef TALLY_DENSITY_HELPER_BY_MASK
  uint live = gl_SampleMaskIn[0] != 0 ? 1u : 0u;
#else
  uint live = gl_HelperInvocation ? 0u : 1u;
#endif
  uint l0 = subgroupQuadBroadcast(live, 0u);
  uint l1 = subgroupQuadBroadcast(live, 1u);
  uint l2 = subgroupQuadBroadcast(live, 2u);
  uint q = gl_SubgroupInvocationID & 3u;
  bool first = live == 1u && (q == 0u || (l0 == 0u && (q == 1u || (l1 == 0u && (q == 2u || l2 == 0u)))));
  return first ? 4.0 : 0.0;
}
#endif

#endif
