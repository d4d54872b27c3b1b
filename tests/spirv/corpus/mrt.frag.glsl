#version 450
// Several outputs at different (non-contiguous) locations, one not written on every path.
layout(set = 0, binding = 0) uniform sampler2D albedo;

layout(location = 0) in vec2 inUv;
layout(location = 1) in vec3 inNormal;
layout(location = 0) out vec4 outAlbedo;
layout(location = 1) out vec4 outNormal;
layout(location = 3) out vec4 outEmissive;

void main() {
  vec4 c = texture(albedo, inUv);
  outAlbedo = c;
  outNormal = vec4(normalize(inNormal) * 0.5 + 0.5, 1.0);
  if (c.a > 0.9) {
    outEmissive = c;
  }
}
