#version 450
// Reads that run exactly once in every invocation, and reads that do not,
// in a fragment shader whose left 100 columns (pixel centres 0.5 .. 99.5)
// return early. Accumulate mode derives the first kind from the invocation
// count and counts the second in the shader; every mode must agree.
//  - albedo: read on entry, before the branch (every invocation), and in
//    firstRead(), called once on every path: 2*W*H;
//  - detail: read after the early return: (W-100)*H;
//  - mask: read in a loop of 3 after the early return, and in maskOnLeft(),
//    called only on the left: 3*(W-100)*H + 100*H;
//  - outputs: written at both returns: W*H; invocations W*H.
layout(set = 0, binding = 0) uniform sampler2D albedo;
layout(set = 0, binding = 1) uniform sampler2D detail;
layout(set = 0, binding = 2) uniform sampler2D mask;

layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;

vec4 firstRead() { return texture(albedo, uv.yx); }
vec4 maskOnLeft() { return texture(mask, uv * 0.5); }

void main() {
  vec4 a = texture(albedo, uv) + firstRead();
  if (gl_FragCoord.x < 100.0) {
    color = a + maskOnLeft();
    return;
  }
  vec4 b = texture(detail, uv * 3.0);
  for (int i = 0; i < 3; ++i) b += texture(mask, uv + vec2(0.25 * float(i), 0.5));
  color = a * 0.5 + b * 0.125;
}
