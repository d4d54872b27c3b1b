#version 450
// textureLod, textureGrad, textureProj, textureOffset, and textureQueryLevels (not counted).
layout(set = 0, binding = 0) uniform sampler2D lodTex;
layout(set = 0, binding = 1) uniform sampler2D gradTex;
layout(set = 1, binding = 0) uniform sampler2D projTex;
layout(set = 1, binding = 1) uniform sampler2D offsetTex;
layout(set = 3, binding = 0) uniform sampler3D volumeTex;

layout(location = 0) in vec2 inUv;
layout(location = 1) in vec4 inProj;
layout(location = 0) out vec4 outColor;

void main() {
  float levels = float(textureQueryLevels(lodTex));
  vec4 a = textureLod(lodTex, inUv, levels - 1.0);
  vec4 b = textureGrad(gradTex, inUv, dFdx(inUv), dFdy(inUv));
  vec4 c = textureProj(projTex, inProj);
  vec4 d = textureOffset(offsetTex, inUv, ivec2(-1, 2));
  vec4 e = textureLodOffset(offsetTex, inUv, 0.0, ivec2(1, 1));
  vec4 f = texture(volumeTex, vec3(inUv, 0.5));
  outColor = a + b + c + d + e + f;
}
