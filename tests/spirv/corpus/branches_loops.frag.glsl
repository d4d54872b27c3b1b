#version 450
// Accesses inside branches and loops; a sampler array indexed by a loop counter
// (glslang does not unroll: a dynamic index).
layout(set = 0, binding = 0) uniform Settings {
  int mode;
  int cascadeCount;
  vec4 weights[4];
} settings;
layout(set = 1, binding = 0) uniform sampler2D cascades[4];
layout(set = 1, binding = 1) uniform sampler2D modeA;
layout(set = 1, binding = 2) uniform sampler2D modeB;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  vec4 sum = vec4(0.0);
  for (int i = 0; i < 4; ++i) {
    if (i >= settings.cascadeCount) break;
    sum += texture(cascades[i], inUv) * settings.weights[i];
  }
  if (settings.mode == 0) {
    sum += texture(modeA, inUv);
  } else if (settings.mode == 1) {
    sum += texture(modeB, inUv);
  } else {
    sum *= 0.5;
  }
  int k = 0;
  while (k < 3) {
    sum += textureLod(modeA, inUv, float(k));
    ++k;
  }
  outColor = sum;
}
