#version 460
#extension GL_GOOGLE_include_directive : require
// Forward renderer: samples the draw's five material maps and shades with
// Blinn-Phong over every light, per fragment that passes the early depth test
// (so overshading in this pass costs maps and lights).
#define TALLY_LIGHTS
#define TALLY_MATERIALS
#ifdef TALLY_DENSITY
// output=density: the triangle's vertices by gl_PrimitiveID (density.h).
#define TALLY_DRAWS
#define TALLY_MESH
#ifdef TALLY_DENSITY_QUADS
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_quad : require
#endif
#endif
#include "common.h"
#ifdef TALLY_DENSITY
#include "density.h"
#endif

// alphaMode MASK draws (TALLY_ALPHA_TEST) discard, so their coverage is
// known only after the shader: no early tests there.
#ifndef TALLY_ALPHA_TEST
layout(early_fragment_tests) in;
#endif
#include "draw_material.h"  // the draw's maps, uvs, vertex colour, alpha test, emission
#ifdef TALLY_TRANSPARENT
#include "tonemap.h"
#endif

layout(location = 0) in vec3 inPosition;

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR
#ifdef TALLY_COUNT_FRAGMENTS
// output=overdraw|overshading: 1 per fragment into the R32_SFLOAT count
// target. The pipeline blends src + dst x (1 - src alpha): alpha 0 adds, and
// outColor's alpha 1 replaces as without blending.
layout(location = kOutCount) out vec4 outCount;
#endif
#ifdef TALLY_DENSITY
// output=density: quad lanes (densityQuadLanes) into the R32_SFLOAT
// "density.lanes" target, additive as outCount.
layout(location = kOutCount + 1) out vec4 outLanes;
#endif

void main() {
#ifdef TALLY_DENSITY
#ifdef TALLY_DENSITY_QUADS
  outLanes = vec4(densityQuadLanes(), 0.0, 0.0, 0.0);
#else
  outLanes = vec4(0.0);  // no quad operations: frameExtras() estimates lanes on the CPU
#endif
#endif
  DrawMaterial d = drawMaterial();
  Surface s = d.surface;
#ifdef TALLY_DENSITY
  outColor = vec4(densityColor(densityClass(push.drawIndex, uint(gl_PrimitiveID)), shade(s, inPosition)), 1.0);
#elif defined(TALLY_TRANSPARENT)
  // alphaMode BLEND, after the sky, into "final": tonemapped here, then
  // blended (premultiplied alpha) by the pipeline in linear space.
  outColor = vec4(tonemapReinhard(shade(s, inPosition) + d.emission, lighting.exposure) * d.alpha, d.alpha);
#else
  outColor = vec4(shade(s, inPosition) + d.emission, 1.0);
#endif
#ifdef TALLY_COUNT_FRAGMENTS
  outCount = vec4(1.0, 0.0, 0.0, 0.0);
#endif
}
