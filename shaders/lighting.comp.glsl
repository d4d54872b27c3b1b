#version 460
#extension GL_GOOGLE_include_directive : require
// Deferred renderer, lighting pass as a compute dispatch (shading=compute;
// docs/techniques.md, "Shading in compute"): 8x8 workgroups, one invocation
// per pixel, the ones past the image's edge return at once. Per pixel: the
// depth texel; where it is the far plane (the clear value: a sky pixel, which
// the fragment version's stencil test masks out) the cleared HDR value is
// stored, else the three G-buffer texels are fetched and shaded exactly as
// lighting.frag does (the pixel centre stands for gl_FragCoord.xy). So: depth
// reads = pixels, G-buffer reads = covered pixels x 1 per target, HDR writes =
// pixels (the fragment version writes covered pixels over a cleared target).
#define TALLY_LIGHTS
#include "common.h"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = kSetPassInput, binding = kBindingDepthTarget) uniform sampler2D depthTarget;  // D32 depth aspect
layout(set = kSetPassInput, binding = kBindingNormalTarget) uniform sampler2D normalTarget;
layout(set = kSetPassInput, binding = kBindingDiffuseTarget) uniform sampler2D diffuseTarget;
layout(set = kSetPassInput, binding = kBindingSpecularTarget) uniform sampler2D specularTarget;
layout(set = kSetPassInput, binding = kBindingHdrImage, rgba16f) uniform writeonly image2D hdrImage;

void main() {
  ivec2 pixel = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(pixel, imageSize(hdrImage)))) return;
  float depth = texelFetch(depthTarget, pixel, 0).r;
  if (depth == 1.0) {
    imageStore(hdrImage, pixel, vec4(0.0));  // the fragment version's cleared value
    return;
  }
  vec2 fragCoord = vec2(pixel) + 0.5;
  Surface s = decodeGBuffer(texelFetch(normalTarget, pixel, 0), texelFetch(diffuseTarget, pixel, 0),
                            texelFetch(specularTarget, pixel, 0));
  imageStore(hdrImage, pixel, vec4(shade(s, worldFromDepth(fragCoord, depth)), 1.0));
}
