#version 450
// Vertex stage SSBO atomic and store (vertexPipelineStoresAndAtomics): writes only.
layout(std430, set = 3, binding = 0) buffer Stats {
  uint vertexCount;
  uint pad;
  vec4 lastPosition[];
} stats;

layout(location = 0) in vec4 inPos;

void main() {
  uint slot = atomicAdd(stats.vertexCount, 1u);
  stats.lastPosition[gl_VertexIndex] = inPos;
  gl_Position = inPos + vec4(float(slot) * 0.0);
}
