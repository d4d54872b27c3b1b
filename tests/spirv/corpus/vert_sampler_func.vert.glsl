#version 450
// Vertex: one function called with two different samplers (explicit LOD).
layout(set = 1, binding = 0) uniform sampler2D offsetsA;
layout(set = 1, binding = 1) uniform sampler2D offsetsB;

layout(location = 0) in vec3 inPos;
layout(location = 1) in vec2 inUv;

vec3 displace(sampler2D tex, vec2 uv) {
  return textureLod(tex, uv, 0.0).xyz;
}

void main() {
  vec3 p = inPos + displace(offsetsA, inUv) + displace(offsetsB, inUv * 2.0);
  gl_Position = vec4(p, 1.0);
}
