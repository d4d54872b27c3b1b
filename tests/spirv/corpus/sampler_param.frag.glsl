#version 450
// One function called twice with two different samplers: both resolve.
layout(set = 0, binding = 1) uniform sampler2D diffuseMap;
layout(set = 1, binding = 2) uniform sampler2D detailMap;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

vec4 sampleScaled(sampler2D tex, vec2 uv, float scale) {
  return texture(tex, uv * scale);
}

void main() {
  vec4 base = sampleScaled(diffuseMap, inUv, 1.0);
  vec4 detail = sampleScaled(detailMap, inUv, 8.0);
  outColor = base * detail;
}
