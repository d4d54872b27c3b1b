#version 450
// The simplest case: one combined sampler, one output.
layout(set = 0, binding = 0) uniform sampler2D albedo;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  outColor = texture(albedo, inUv);
}
