#version 450
#extension GL_ARB_sparse_texture2 : require
// Sparse residency: sparseTextureARB and sparseTexelFetchARB.
layout(set = 2, binding = 0) uniform sampler2D virtualTex;
layout(set = 2, binding = 1) uniform sampler2D fallbackTex;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  vec4 texel;
  int code = sparseTextureARB(virtualTex, inUv, texel);
  if (!sparseTexelsResidentARB(code)) {
    vec4 fetched;
    int code2 = sparseTexelFetchARB(fallbackTex, ivec2(gl_FragCoord.xy), 0, fetched);
    texel = sparseTexelsResidentARB(code2) ? fetched : vec4(1.0, 0.0, 1.0, 1.0);
  }
  outColor = texel;
}
