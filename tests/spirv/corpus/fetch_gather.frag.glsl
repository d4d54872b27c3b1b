#version 450
// texelFetch, textureGather, textureGatherOffset.
layout(set = 0, binding = 3) uniform sampler2D gbuffer;
layout(set = 2, binding = 2) uniform sampler2D ao;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  vec4 texel = texelFetch(gbuffer, ivec2(gl_FragCoord.xy), 0);
  vec4 reds = textureGather(ao, inUv, 0);
  vec4 greens = textureGatherOffset(ao, inUv, ivec2(1, 0), 1);
  outColor = texel + reds + greens;
}
