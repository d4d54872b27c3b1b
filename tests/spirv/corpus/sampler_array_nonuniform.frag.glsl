#version 450
#extension GL_EXT_nonuniform_qualifier : require
// Non-uniform dynamic index into a sampler array (descriptor indexing).
layout(set = 3, binding = 2) uniform sampler2D materials[16];

layout(location = 0) in vec2 inUv;
layout(location = 1) flat in int inMaterial;
layout(location = 0) out vec4 outColor;

void main() {
  int i = inMaterial;
  outColor = texture(materials[nonuniformEXT(i)], inUv);
}
