#version 450
// Skinning: a loop indexes an array MEMBER of a UBO (not a descriptor index).
layout(set = 0, binding = 0) uniform Frame {
  mat4 viewProj;
} frame;

layout(set = 2, binding = 3) uniform Bones {
  mat4 bones[64];
  int boneCount;
} skin;

layout(location = 0) in vec3 inPos;
layout(location = 1) in uvec4 inJoints;
layout(location = 2) in vec4 inWeights;

void main() {
  vec4 pos = vec4(0.0);
  for (int i = 0; i < 4; ++i) {
    uint joint = inJoints[i];
    if (int(joint) < skin.boneCount) {
      pos += inWeights[i] * (skin.bones[joint] * vec4(inPos, 1.0));
    }
  }
  gl_Position = frame.viewProj * pos;
}
