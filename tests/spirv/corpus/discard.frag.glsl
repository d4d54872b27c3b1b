#version 450
// Alpha test with discard.
layout(set = 0, binding = 0) uniform sampler2D albedo;
layout(set = 0, binding = 1) uniform Cutoff {
  float alphaCutoff;
} cutoff;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  vec4 c = texture(albedo, inUv);
  if (c.a < cutoff.alphaCutoff) {
    discard;
  }
  outColor = c;
}
