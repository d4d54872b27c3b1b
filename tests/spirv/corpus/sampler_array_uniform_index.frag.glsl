#version 450
// A dynamically uniform index from a UBO into a sampler array, plus a constant index.
layout(set = 0, binding = 0) uniform Material {
  int albedoIndex;
  int pad0;
  vec2 uvScale;
} material;
layout(set = 1, binding = 1) uniform sampler2D textures[8];

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  vec2 uv = inUv * material.uvScale;
  vec4 albedo = texture(textures[material.albedoIndex], uv);
  vec4 fallback = texture(textures[7], uv);
  outColor = albedo * fallback;
}
