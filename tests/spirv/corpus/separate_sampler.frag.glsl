#version 450
// Separate texture2D + sampler combined with sampler2D(t, s): the resource is t.
layout(set = 0, binding = 0) uniform texture2D colorTex;
layout(set = 0, binding = 1) uniform sampler linearSampler;
layout(set = 1, binding = 0) uniform texture2D extraTex[3];
layout(set = 1, binding = 5) uniform sampler pointSampler;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  vec4 a = texture(sampler2D(colorTex, linearSampler), inUv);
  vec4 b = texture(sampler2D(colorTex, pointSampler), inUv);
  vec4 c = texture(sampler2D(extraTex[2], linearSampler), inUv);
  outColor = a + b + c;
}
