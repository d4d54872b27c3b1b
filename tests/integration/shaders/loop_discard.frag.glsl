#version 450
// loop_demote.frag.glsl with discard (OpKill) for demote: the left 100
// columns end in the second of four iterations, after that iteration's
// albedo and detail reads and before its mask read. The flush there must add what the trip
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
      discard;
    }
    c += texture(mask, uv + vec2(0.0, 0.25 * float(i)));
  }
  for (int i = 0; i < 3; ++i) c += texture(albedo, uv * 0.5 + vec2(0.0625 * float(i)));
  color = c * 0.05;
}
