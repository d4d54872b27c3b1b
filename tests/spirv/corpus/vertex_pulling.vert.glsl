#version 450
// Vertex pulling: SSBO array of structs read by gl_VertexIndex, UBO in another set.
struct Vertex {
  vec4 position;
  vec4 normal;
  vec2 uv;
  vec2 pad;
};

layout(std430, set = 1, binding = 0) readonly buffer Vertices {
  Vertex vertices[];
};

layout(set = 0, binding = 2) uniform Frame {
  mat4 viewProj;
} frame;

layout(location = 0) out vec2 outUv;
layout(location = 1) out vec3 outNormal;

void main() {
  Vertex v = vertices[gl_VertexIndex];
  gl_Position = frame.viewProj * v.position;
  outUv = v.uv;
  outNormal = v.normal.xyz;
}
