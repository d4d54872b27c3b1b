#version 450
// Shadow samplers: texture() with Dref, textureProj shadow, textureGather with Dref.
layout(set = 1, binding = 4) uniform sampler2DShadow shadowMap;
layout(set = 1, binding = 5) uniform samplerCubeShadow pointShadow;

layout(location = 0) in vec4 inShadowCoord;
layout(location = 1) in vec3 inLightDir;
layout(location = 0) out vec4 outColor;

void main() {
  float s0 = texture(shadowMap, inShadowCoord.xyz);
  float s1 = textureProj(shadowMap, inShadowCoord);
  vec4 s2 = textureGather(shadowMap, inShadowCoord.xy, inShadowCoord.z);
  float s3 = texture(pointShadow, vec4(inLightDir, 0.5));
  float lit = (s0 + s1 + dot(s2, vec4(0.25)) + s3) * 0.25;
  outColor = vec4(vec3(lit), 1.0);
}
