#version 450
// A UBO descriptor array with constant indices, and an array member indexed dynamically.
layout(set = 1, binding = 2) uniform Transforms {
  mat4 matrices[16];
} transforms[3];

layout(location = 0) in vec3 inPos;
layout(location = 1) in int inBone;

void main() {
  mat4 view = transforms[0].matrices[0];
  mat4 model = transforms[2].matrices[inBone];
  gl_Position = view * model * vec4(inPos, 1.0);
}
