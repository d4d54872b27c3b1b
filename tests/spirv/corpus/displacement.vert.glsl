#version 450
// Vertex texture fetch: textureLod (vertex has no implicit LOD), textureSize is not counted.
layout(set = 2, binding = 1) uniform sampler2D heightMap;
layout(set = 0, binding = 0) uniform Terrain {
  mat4 viewProj;
  float scale;
} terrain;

layout(location = 0) in vec2 inXZ;
layout(location = 0) out vec2 outUv;

void main() {
  ivec2 size = textureSize(heightMap, 0);
  vec2 uv = inXZ / vec2(size);
  float h = textureLod(heightMap, uv, 0.0).r;
  outUv = uv;
  gl_Position = terrain.viewProj * vec4(inXZ.x, h * terrain.scale, inXZ.y, 1.0);
}
