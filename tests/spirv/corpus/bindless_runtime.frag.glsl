#version 450
#extension GL_EXT_nonuniform_qualifier : require
// A runtime-sized (unbounded) sampler array and SSBO material table, non-uniform index.
struct MaterialInfo {
  uint albedo;
  uint normal;
  vec2 pad;
};
layout(std430, set = 0, binding = 0) readonly buffer Materials {
  MaterialInfo materials[];
};
layout(set = 1, binding = 0) uniform sampler2D bindless[];

layout(location = 0) in vec2 inUv;
layout(location = 1) flat in uint inMaterial;
layout(location = 0) out vec4 outColor;
layout(location = 1) out vec4 outNormal;

void main() {
  MaterialInfo m = materials[inMaterial];
  outColor = texture(bindless[nonuniformEXT(m.albedo)], inUv);
  outNormal = texture(bindless[nonuniformEXT(m.normal)], inUv);
}
