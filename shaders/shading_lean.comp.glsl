#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_nonuniform_qualifier : require
// Lean visibility buffer, shading pass as a compute dispatch (shading=compute;
// docs/techniques.md, "Shading in compute"): 8x8 workgroups, one invocation
// per pixel, the ones past the image's edge return at once. Per pixel: the id
// texel; the clear id (a sky pixel, which the fragment version's stencil test
// masks out) stores the cleared HDR value, any other runs shading_lean.frag's
// shadeTriangle (visbuffer_shade.h) at the pixel centre, which is what
// gl_FragCoord.xy is there. So: id reads = pixels, map and geometry reads as
// shading_lean.frag's, HDR writes = pixels.
#define TALLY_LIGHTS
#define TALLY_DRAWS
#define TALLY_MATERIALS
#define TALLY_MESH
#include "common.h"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = kSetPassInput, binding = kBindingVisibilityTarget) uniform usampler2D visibilityTarget;  // R32_UINT
layout(set = kSetPassInput, binding = kBindingHdrImage, rgba16f) uniform writeonly image2D hdrImage;

#define TALLY_SHADE_LEAN
#include "visbuffer_shade.h"

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, imageSize(hdrImage)))) return;
  uint id = texelFetch(visibilityTarget, pixel, 0).r;
  if (id == kVisibilityClear) {
    imageStore(hdrImage, pixel, vec4(0.0));  // the fragment version's cleared value
    return;
  }
  imageStore(hdrImage, pixel, vec4(shadeTriangle(id, vec2(pixel) + 0.5), 1.0));
}
