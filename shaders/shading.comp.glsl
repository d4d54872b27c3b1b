#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_nonuniform_qualifier : require
// Fat visibility buffer, shading pass as a compute dispatch (shading=compute;
// docs/techniques.md, "Shading in compute"): 8x8 workgroups, one invocation
// per pixel, the ones past the image's edge return at once. Per pixel: the id
// texel; the clear id (a sky pixel, which the fragment version's stencil test
// masks out) stores the cleared HDR value, any other fetches the derivative
// texel and runs shading.frag's shadeTriangle (visbuffer_shade.h). So: id
// reads = pixels, derivative reads = covered pixels, map and geometry reads
// as shading.frag's, HDR writes = pixels.
#define TALLY_LIGHTS
#define TALLY_DRAWS
#define TALLY_MATERIALS
#define TALLY_MESH
#include "common.h"
#include "visibility_encoding.h"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = kSetPassInput, binding = kBindingVisibilityTarget) uniform usampler2D visibilityTarget;
layout(set = kSetPassInput, binding = kBindingUvDerivativeTarget) uniform usampler2D uvDerivativeTarget;
layout(set = kSetPassInput, binding = kBindingHdrImage, rgba16f) uniform writeonly image2D hdrImage;

#define TALLY_SHADE_FAT
#include "visbuffer_shade.h"

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, imageSize(hdrImage)))) return;
  uvec4 visibility = texelFetch(visibilityTarget, pixel, 0);
  if (visibility.x == kVisibilityClear) {
    imageStore(hdrImage, pixel, vec4(0.0));  // the fragment version's cleared value
    return;
  }
  imageStore(hdrImage, pixel, vec4(shadeTriangle(visibility, texelFetch(uvDerivativeTarget, pixel, 0)), 1.0));
}
