#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_nonuniform_qualifier : require
// Lean visibility buffer (Burns & Hunt 2013), shading pass (full screen):
// from the 32-bit id alone, fetch the triangle, project its three vertices
// again and derive the perspective-correct barycentrics at the pixel centre
// and their change across one pixel; uv derivatives follow from those.
// Same resources as shading.frag but one visibility target instead of two.
#define TALLY_LIGHTS
#define TALLY_DRAWS
#define TALLY_MATERIALS
#define TALLY_MESH
#include "common.h"

#ifdef TALLY_MSAA
// MSAA (RendererOptions::msaa = TALLY_MSAA samples, renderers/techniques/msaa.hpp): the
// visibility targets are multisampled. Every sample's id is fetched; each
// distinct triangle among the covered samples (id != kVisibilityClear) is
// shaded once (with the texels of its first sample), weighted by its samples;
// the pixel is the covered samples' mean. No covered sample: discard, so the
// stencil REPLACE of the pass marks only geometry pixels (late tests: no
// early_fragment_tests here, or discarded pixels would be marked too).
layout(set = kSetPassInput, binding = kBindingVisibilityTarget) uniform usampler2DMS visibilityTarget;
#else
layout(early_fragment_tests) in;

layout(set = kSetPassInput, binding = kBindingVisibilityTarget) uniform usampler2D visibilityTarget;  // R32_UINT
#endif

#define TALLY_SHADE_LEAN
#include "visbuffer_shade.h"

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR

#ifdef TALLY_MSAA
void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  uint ids[TALLY_MSAA];
  for (int i = 0; i < TALLY_MSAA; ++i) ids[i] = texelFetch(visibilityTarget, pixel, i).r;
  vec3 sum = vec3(0.0);
  int covered = 0;
  for (int i = 0; i < TALLY_MSAA; ++i) {
    if (ids[i] == kVisibilityClear) continue;
    ++covered;
    int weight = 0;
    bool first = true;
    for (int j = 0; j < TALLY_MSAA; ++j) {
      if (ids[j] == ids[i]) {
        ++weight;
        if (j < i) first = false;
      }
    }
    if (first) sum += float(weight) * shadeTriangle(ids[i], gl_FragCoord.xy);
  }
  if (covered == 0) discard;
  outColor = vec4(sum / float(covered), 1.0);
}
#else
void main() {
  outColor = vec4(shadeTriangle(texelFetch(visibilityTarget, ivec2(gl_FragCoord.xy), 0).r, gl_FragCoord.xy), 1.0);
}
#endif
