#version 450
// Only push constants and texture queries: no memory sites besides the output.
layout(push_constant) uniform Push {
  vec4 color;
  int level;
} pc;
layout(set = 0, binding = 0) uniform sampler2D sizedTex;

layout(location = 0) out vec4 outColor;

void main() {
  ivec2 size = textureSize(sizedTex, pc.level);
  int levels = textureQueryLevels(sizedTex);
  outColor = pc.color * float(size.x + size.y + levels);
}
