#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_nonuniform_qualifier : require
// Fat visibility buffer, shading pass (full screen, after fullscreen.vert):
// per covered pixel, the two visibility texels, the draw, 3 indices and 3
// vertices, the material's map indices, then the five maps with the stored uv
// derivatives and Blinn-Phong. Stencil masks sky pixels out. Map reads are
// bounded by covered pixels x 5 whatever the overshading of pass 1.
#define TALLY_LIGHTS
#define TALLY_DRAWS
#define TALLY_MATERIALS
#define TALLY_MESH
#include "common.h"
#include "visibility_encoding.h"

#ifdef TALLY_MSAA
// MSAA (RendererOptions::msaa = TALLY_MSAA samples, renderers/techniques/msaa.hpp): the
// visibility targets are multisampled. Every sample's id is fetched; each
// distinct triangle among the covered samples (id != kVisibilityClear) is
// shaded once (with the texels of its first sample), weighted by its samples;
// the pixel is the covered samples' mean. No covered sample: discard, so the
// stencil REPLACE of the pass marks only geometry pixels (late tests: no
// early_fragment_tests here, or discarded pixels would be marked too).
layout(set = kSetPassInput, binding = kBindingVisibilityTarget) uniform usampler2DMS visibilityTarget;
layout(set = kSetPassInput, binding = kBindingUvDerivativeTarget) uniform usampler2DMS uvDerivativeTarget;
#else
layout(early_fragment_tests) in;

layout(set = kSetPassInput, binding = kBindingVisibilityTarget) uniform usampler2D visibilityTarget;
layout(set = kSetPassInput, binding = kBindingUvDerivativeTarget) uniform usampler2D uvDerivativeTarget;
#endif

// Every map of the scene; the material is known only per pixel, so the index
// is non-uniform (shaderSampledImageArrayNonUniformIndexing: NVIDIA has it).
// lavapipe has no descriptor indexing at all (not even dynamically uniform
// indexing) and 32 samplers per stage: the renderer needs a fallback there,
// e.g. one sampler2DArray per map kind with the material as the layer.
// Material selection (RendererOptions::materialSelection), defined by the
// renderer; by default the per-pixel selection above. TALLY_SELECT_UNIFORM:
// the index without nonuniformEXT, as the founding study wrote it (undefined
// unless dynamically uniform: what the driver does is what is measured).
// TALLY_SELECT_FIRST_LANE: every lane takes the first active lane's index or
// layer, a model of a driver that scalarises the index.
#define TALLY_SHADE_FAT
#include "visbuffer_shade.h"

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR

#ifdef TALLY_MSAA
void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  uvec4 visibility[TALLY_MSAA];
  for (int i = 0; i < TALLY_MSAA; ++i) visibility[i] = texelFetch(visibilityTarget, pixel, i);
  vec3 sum = vec3(0.0);
  int covered = 0;
  for (int i = 0; i < TALLY_MSAA; ++i) {
    if (visibility[i].x == kVisibilityClear) continue;
    ++covered;
    int weight = 0;
    bool first = true;
    for (int j = 0; j < TALLY_MSAA; ++j) {
      if (visibility[j].x == visibility[i].x) {
        ++weight;
        if (j < i) first = false;
      }
    }
    if (first) sum += float(weight) * shadeTriangle(visibility[i], texelFetch(uvDerivativeTarget, pixel, i));
  }
  if (covered == 0) discard;
  outColor = vec4(sum / float(covered), 1.0);
}
#else
void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  outColor = vec4(shadeTriangle(texelFetch(visibilityTarget, pixel, 0), texelFetch(uvDerivativeTarget, pixel, 0)), 1.0);
}
#endif
