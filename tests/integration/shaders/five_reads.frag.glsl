#version 450
// K = 5 texture reads per pixel from 3 sampler2D bindings, one colour output.
// The counts of a full-screen pass are known: W*H*5 texture reads, W*H
// invocations, W*H output writes.
layout(set = 0, binding = 0) uniform sampler2D albedo;
layout(set = 0, binding = 1) uniform sampler2D detail;
layout(set = 0, binding = 2) uniform sampler2D mask;

layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;

void main() {
  vec4 a = texture(albedo, uv);
  vec4 b = texture(detail, uv * 3.0);
  vec4 c = texture(mask, uv + vec2(0.25, 0.5));
  vec4 d = texture(albedo, uv.yx * 2.0);
  vec4 e = texture(detail, uv * 0.5 + 0.125);
  color = a * 0.4 + b * 0.2 + c * 0.2 + d * 0.1 + e * 0.1;
}
