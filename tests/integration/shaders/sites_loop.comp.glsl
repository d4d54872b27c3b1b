#version 450
// mixed_reads.comp.glsl's bindings; per-site counts by hand over the W x H
// invocations in bounds (x = 0 .. W-1):
//  - [once]   source texelFetch, outside any loop: W*H
//  - [fixed]  inputBuffer load, in a loop of 4 trips: 4*W*H
//  - [varied] inputImage load, in a loop of (x mod 3) trips: H * sum over x of (x mod 3)
//  - [store]  outputBuffer store, once: W*H
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D source;
layout(set = 0, binding = 1, rgba8) uniform readonly image2D inputImage;
layout(set = 0, binding = 2) readonly buffer Input { uint values[]; } inputBuffer;
layout(set = 0, binding = 3) writeonly buffer Output { uint values[]; } outputBuffer;
layout(set = 0, binding = 4, rgba8) uniform writeonly image2D outputImage;

layout(push_constant) uniform Size { uvec2 extent; } size;

void main() {
  uvec2 id = gl_GlobalInvocationID.xy;
  if (id.x >= size.extent.x || id.y >= size.extent.y) return;
  ivec2 p = ivec2(id);
  vec4 a = texelFetch(source, p % ivec2(16, 16), 0);  // [once]
  uint index = id.y * size.extent.x + id.x;
  uint v = 0u;
  for (uint i = 0u; i < 4u; ++i) {
    v += inputBuffer.values[(index + i) % (size.extent.x * size.extent.y)];  // [fixed]
  }
  for (uint i = 0u; i < id.x % 3u; ++i) {
    a += imageLoad(inputImage, ivec2(p.x, (p.y + int(i)) % int(size.extent.y)));  // [varied]
  }
  outputBuffer.values[index] = v + uint(a.x * 255.0);  // [store]
}
