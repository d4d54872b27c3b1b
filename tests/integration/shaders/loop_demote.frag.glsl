#version 450
#extension GL_EXT_demote_to_helper_invocation : require
// A loop that ends the invocation part-way: the left 100 columns (pixel
// centres 0.5 .. 99.5) demote in the second of four iterations, after that
// iteration's albedo and detail reads and before its mask read (what they
// read as helpers is not counted). The flush there must add what the trip
// counter holds, this iteration included. A counted loop of 3 follows.
// Counts at W x H (W > 100): albedo 7*(W-100)*H + 2*100*H, detail
// 4*(W-100)*H + 2*100*H, mask 4*(W-100)*H + 100*H, outputs (W-100)*H,
// invocations W*H.
layout(set = 0, binding = 0) uniform sampler2D albedo;
layout(set = 0, binding = 1) uniform sampler2D detail;
layout(set = 0, binding = 2) uniform sampler2D mask;

layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;

void main() {
  vec4 c = vec4(0.0);
  for (int i = 0; i < 4; ++i) {
    c += texture(albedo, uv + vec2(0.125 * float(i), 0.0));
    c += texture(detail, uv * float(i + 1));
    if (i == 1 && gl_FragCoord.x < 100.0) {
      demote;
    }
    c += texture(mask, uv + vec2(0.0, 0.25 * float(i)));
  }
  for (int i = 0; i < 3; ++i) c += texture(albedo, uv * 0.5 + vec2(0.0625 * float(i)));
  color = c * 0.05;
}
