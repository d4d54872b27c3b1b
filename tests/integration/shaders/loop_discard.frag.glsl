#version 450
// loop_demote.frag.glsl with a discard (OpKill) in a function the loop
// calls: the left 100 columns end in the second of four iterations, after
// that iteration's albedo and detail reads and before its mask read, all
// three in one block, with the call between them. The same counts at W x H
// (W > 100): albedo 7*(W-100)*H + 2*100*H, detail 4*(W-100)*H + 2*100*H,
// mask 4*(W-100)*H + 100*H, outputs (W-100)*H, invocations W*H.
layout(set = 0, binding = 0) uniform sampler2D albedo;
layout(set = 0, binding = 1) uniform sampler2D detail;
layout(set = 0, binding = 2) uniform sampler2D mask;

layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;

void endOnTheLeft(int i) {
  if (i == 1 && gl_FragCoord.x < 100.0) discard;
}

void main() {
  vec4 sum = vec4(0.0);
  int i = 0;
  while (i < 4) {
    vec4 a = texture(albedo, uv + vec2(0.125 * float(i), 0.0)) + texture(detail, uv * float(i + 1));
    endOnTheLeft(i);
    sum += a + texture(mask, uv + vec2(0.0, 0.25 * float(i)));
    i++;
  }
  for (int k = 2; k >= 0; --k) sum += texture(albedo, uv * 0.5 + vec2(0.0625 * float(k)));
  color = sum * 0.05;
}
