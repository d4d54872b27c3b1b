#version 450
// UBO array of structs in a loop (a member index, not a descriptor index), whole-struct copy.
struct Light {
  vec4 position;
  vec4 color;
  float radius;
  float pad0;
  float pad1;
  float pad2;
};

layout(set = 0, binding = 1) uniform Lights {
  Light lights[8];
  int lightCount;
} ubo;
layout(set = 2, binding = 3) uniform sampler2D normalMap;

layout(location = 0) in vec3 inWorldPos;
layout(location = 1) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  vec3 n = normalize(texture(normalMap, inUv).xyz * 2.0 - 1.0);
  vec3 result = vec3(0.0);
  for (int i = 0; i < ubo.lightCount; ++i) {
    Light l = ubo.lights[i];
    vec3 toLight = l.position.xyz - inWorldPos;
    float dist = length(toLight);
    if (dist > ubo.lights[i].radius) {
      continue;
    }
    result += l.color.rgb * max(dot(n, toLight / dist), 0.0);
  }
  outColor = vec4(result, 1.0);
}
