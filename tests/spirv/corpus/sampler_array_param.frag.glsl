#version 450
// Elements of a sampler array passed to a function: constant and dynamic indices.
layout(set = 2, binding = 5) uniform sampler2D decals[6];
layout(set = 0, binding = 2) uniform Decals {
  int activeIndex;
} decalInfo;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

vec4 sampleDecal(sampler2D tex, vec2 uv) {
  return texture(tex, uv);
}

void main() {
  vec4 base = sampleDecal(decals[1], inUv);
  vec4 current = sampleDecal(decals[decalInfo.activeIndex], inUv);
  outColor = base + current;
}
