#version 450
// Input attachments: subpassLoad is attachment_read, not texture_read.
layout(input_attachment_index = 0, set = 0, binding = 0) uniform subpassInput inAlbedo;
layout(input_attachment_index = 1, set = 0, binding = 1) uniform subpassInput inNormal;
layout(set = 1, binding = 0) uniform Light {
  vec4 direction;
  vec4 color;
} light;

layout(location = 0) out vec4 outColor;

void main() {
  vec4 albedo = subpassLoad(inAlbedo);
  vec3 n = normalize(subpassLoad(inNormal).xyz * 2.0 - 1.0);
  float ndl = max(dot(n, -light.direction.xyz), 0.0);
  outColor = vec4(albedo.rgb * light.color.rgb * ndl, albedo.a);
}
