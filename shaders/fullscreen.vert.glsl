#version 460
// Full-screen passes (lighting, shading, tonemap): one triangle covering the
// viewport, from gl_VertexIndex 0..2 with no vertex buffer. Draw 3 vertices.
layout(location = 0) out vec2 outUv;  // [0, 1] across the viewport

void main() {
  vec2 uv = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);  // (0,0) (2,0) (0,2)
  outUv = uv;
  gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
