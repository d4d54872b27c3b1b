#version 460
#extension GL_GOOGLE_include_directive : require
// Deferred renderer, gbuffer=subpass: the lighting subpass of the G-buffer's
// render pass. As lighting.frag, but the G-buffer targets are input
// attachments read by subpassLoad, the attribute "attachment_read" in the
// site table: on a tile-based GPU they never leave tile memory. Depth is read
// through the sampled depth view, as in lighting.frag: it is stored for the
// skybox anyway, and on the H200 the depth aspect read as an input attachment
// differed from the sampled one (docs/techniques.md, "Tile memory").
#define TALLY_LIGHTS
#include "common.h"

layout(early_fragment_tests) in;

layout(set = kSetPassInput, binding = kBindingDepthTarget) uniform sampler2D depthTarget;  // D32 depth aspect
layout(input_attachment_index = 0, set = kSetPassInput, binding = kBindingNormalTarget) uniform subpassInput normalInput;
layout(input_attachment_index = 1, set = kSetPassInput, binding = kBindingDiffuseTarget) uniform subpassInput diffuseInput;
layout(input_attachment_index = 2, set = kSetPassInput, binding = kBindingSpecularTarget) uniform subpassInput specularInput;

layout(location = kOutColor) out vec4 outColor;  // RGBA16F HDR

void main() {
  float depth = texelFetch(depthTarget, ivec2(gl_FragCoord.xy), 0).r;
  Surface s = decodeGBuffer(subpassLoad(normalInput), subpassLoad(diffuseInput), subpassLoad(specularInput));
  outColor = vec4(shade(s, worldFromDepth(gl_FragCoord.xy, depth)), 1.0);
}
