#version 450
// fullscreen.vert.glsl's triangle (3 vertices per draw), with reads whose
// per-site counts are known by hand:
//  - [once]   albedo, outside any loop: 3
//  - [fixed]  detail, in a loop of 4 trips: 12
//  - [varied] mask, in a loop of gl_VertexIndex trips: 0 + 1 + 2 = 3
layout(set = 0, binding = 0) uniform sampler2D albedo;
layout(set = 0, binding = 1) uniform sampler2D detail;
layout(set = 0, binding = 2) uniform sampler2D mask;

layout(location = 0) out vec2 uv;

void main() {
  vec2 p = vec2(float((gl_VertexIndex << 1) & 2), float(gl_VertexIndex & 2));
  float bias = textureLod(albedo, p, 0.0).x;  // [once]
  for (int i = 0; i < 4; ++i) {
    bias += textureLod(detail, p * float(i), 0.0).y;  // [fixed]
  }
  for (int i = 0; i < gl_VertexIndex; ++i) {
    bias += textureLod(mask, p + float(i), 0.0).z;  // [varied]
  }
  uv = p + vec2(bias * 1e-9);
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
