#version 450
// gl_FragDepth is a built-in output without a Location: not an output_write.
layout(set = 3, binding = 1) uniform sampler2D depthTex;

layout(location = 0) in vec2 inUv;
layout(location = 2) out vec4 outVelocity;

void main() {
  float d = texture(depthTex, inUv).r;
  gl_FragDepth = d;
  outVelocity = vec4(d);
}
