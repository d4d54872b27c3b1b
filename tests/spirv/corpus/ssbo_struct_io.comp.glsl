#version 450
// Struct read from one SSBO and written whole to another, a UBO array member index,
// and a read-modify-write of a scalar in a branch.
layout(local_size_x = 64) in;

struct Instance {
  mat4 transform;
  vec4 color;
  uint meshIndex;
  uint flags;
  uint pad0;
  uint pad1;
};

layout(std430, set = 0, binding = 0) readonly buffer InInstances {
  Instance inInstances[];
};
layout(std430, set = 0, binding = 1) buffer OutInstances {
  uint visibleCount;
  uint pad[3];
  Instance outInstances[];
};
layout(set = 1, binding = 0) uniform Meshes {
  vec4 boundingSpheres[32];
} meshes;

void main() {
  uint i = gl_GlobalInvocationID.x;
  Instance inst = inInstances[i];
  vec4 sphere = meshes.boundingSpheres[inst.meshIndex];
  if (sphere.w > 0.0 && (inst.flags & 1u) != 0u) {
    outInstances[i] = inst;
    visibleCount += 1u;
  }
}
