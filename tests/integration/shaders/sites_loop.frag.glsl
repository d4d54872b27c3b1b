#version 450
// Per-site counts by hand, over a W x H full-screen triangle (pixel columns
// x = 0 .. W-1). Each marked line holds one read; its count:
//  - [once]   albedo, outside any loop: W*H
//  - [fixed]  detail, in a loop of 3 trips: 3*W*H
//  - [varied] mask, in a loop of (x mod 4) trips: H * sum over x of (x mod 4)
//  - [branch] albedo again, only where x is even: ceil(W/2)*H
//  - [merge]  detail at a coordinate chosen by `?:`: W*H. The read sits in
//    the selection's merge block, which glslang gives no line of its own
layout(set = 0, binding = 0) uniform sampler2D albedo;
layout(set = 0, binding = 1) uniform sampler2D detail;
layout(set = 0, binding = 2) uniform sampler2D mask;

layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 color;

void main() {
  vec4 sum = texture(albedo, uv);  // [once]
  for (int i = 0; i < 3; ++i) {
    sum += texture(detail, uv + vec2(0.125 * float(i), 0.0));  // [fixed]
  }
  int trips = int(gl_FragCoord.x) % 4;
  for (int i = 0; i < trips; ++i) {
    sum += texture(mask, uv * float(i + 1));  // [varied]
  }
  if (int(gl_FragCoord.x) % 2 == 0) {
    sum += texture(albedo, uv.yx);  // [branch]
  }
  sum += texture(detail, int(gl_FragCoord.x) % 3 == 0 ? uv : uv.yx);  // [merge]
  color = sum * 0.125;
}
