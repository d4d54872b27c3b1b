#version 460
#extension GL_GOOGLE_include_directive : require
// Deferred renderer, G-buffer pass: samples the draw's five material maps and
// writes the surface to three targets; depth (D32_S8) carries the position.
// Every fragment that passes the early depth test pays the maps and the
// three writes, so overshading costs here rather than in lighting.frag.
#define TALLY_MATERIALS
#include "common.h"

#ifndef TALLY_ALPHA_TEST  // alphaMode MASK draws discard: no early tests there
layout(early_fragment_tests) in;
#endif
// The draw's maps, uvs, vertex colour, alpha test and emission. Location 0
// (world position) is not read: lighting.frag reconstructs it from depth.
#include "draw_material.h"

layout(location = kOutNormal) out vec4 outNormal;      // RGBA16F
layout(location = kOutDiffuse) out vec4 outDiffuse;    // RGBA8
layout(location = kOutSpecular) out vec4 outSpecular;  // RGBA8
#ifdef TALLY_EMISSIVE
layout(location = kOutEmissive) out vec4 outEmissive;  // RGBA16F "gbuffer.emissive" (glTF emissive scenes)
#endif

void main() {
  DrawMaterial d = drawMaterial();
  encodeGBuffer(d.surface, outNormal, outDiffuse, outSpecular);
#ifdef TALLY_EMISSIVE
  outEmissive = vec4(d.emission, 0.0);
#endif
}
