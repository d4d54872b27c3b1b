#version 450
// Vertex: UBO matrix read; push constants are not counted.
layout(set = 0, binding = 0) uniform Camera {
  mat4 viewProj;
  vec4 eye;
} camera;

layout(push_constant) uniform Push {
  mat4 model;
  vec4 tint;
} pc;

layout(location = 0) in vec3 inPos;
layout(location = 1) in vec3 inNormal;
layout(location = 0) out vec3 outNormal;
layout(location = 1) out vec4 outTint;

void main() {
  vec4 world = pc.model * vec4(inPos, 1.0);
  gl_Position = camera.viewProj * world;
  outNormal = inNormal;
  outTint = pc.tint;
}
