#version 450
// A sampler2D array indexed with constants.
layout(set = 1, binding = 0) uniform sampler2D layers[4];

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  vec4 a = texture(layers[0], inUv);
  vec4 b = texture(layers[3], inUv);
  vec4 c = texture(layers[3], inUv * 0.5);
  outColor = mix(a, b, 0.5) + c;
}
