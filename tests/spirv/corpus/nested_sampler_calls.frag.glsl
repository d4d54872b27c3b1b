#version 450
// Samplers passed through nested calls: main -> blur -> tap, and a second chain.
layout(set = 2, binding = 0) uniform sampler2D sceneColor;
layout(set = 2, binding = 1) uniform sampler2D bloomColor;
layout(set = 0, binding = 0) uniform Params {
  vec2 texelSize;
  float bloomStrength;
} params;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

vec4 tap(sampler2D tex, vec2 uv, vec2 offset) {
  return texture(tex, uv + offset * params.texelSize);
}

vec4 blur(sampler2D tex, vec2 uv) {
  vec4 sum = vec4(0.0);
  sum += tap(tex, uv, vec2(-1.0, 0.0));
  sum += tap(tex, uv, vec2(1.0, 0.0));
  sum += tap(tex, uv, vec2(0.0, -1.0));
  sum += tap(tex, uv, vec2(0.0, 1.0));
  return sum * 0.25;
}

vec4 composite(sampler2D base, sampler2D glow, vec2 uv) {
  return texture(base, uv) + blur(glow, uv) * params.bloomStrength;
}

void main() {
  outColor = composite(sceneColor, bloomColor, inUv);
}
