#version 450
// Two reads through a descriptor array of 20 storage buffers (binding 5,
// every element the input buffer): past the 16 elements the accumulate mode
// keeps in registers, so each site caches one element per invocation, adds
// the cached count when the element changes and flushes what it holds at the
// end, every cache of the stage in one waterfall. The index is uniform in a
// workgroup (lavapipe indexes storage-buffer arrays dynamically, not
// non-uniformly). Per in-bounds invocation of workgroup (gx, gy), for each
// of 9 iterations i:
//   site A reads element (gx + gy + i / 3) % 20   (a new element every 3 iterations)
//   site B reads element (2 gx + i) % 20          (a new element every iteration)
// and one buffer write. The test adds these up per element by hand.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 3) writeonly buffer Output { uint values[]; } outputBuffer;
layout(set = 0, binding = 5) readonly buffer Arrayed { uint values[]; } arrayed[20];

layout(push_constant) uniform Size { uvec2 extent; } size;

void main() {
  uvec2 id = gl_GlobalInvocationID.xy;
  if (id.x >= size.extent.x || id.y >= size.extent.y) return;
  uvec2 g = gl_WorkGroupID.xy;
  uint index = id.y * size.extent.x + id.x;
  uint sum = 0u;
  for (uint i = 0u; i < 9u; ++i) {
    sum += arrayed[(g.x + g.y + i / 3u) % 20u].values[index];
    sum += arrayed[(2u * g.x + i) % 20u].values[index];
  }
  outputBuffer.values[index] = sum;
}
