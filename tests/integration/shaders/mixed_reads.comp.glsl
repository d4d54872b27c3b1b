#version 450
// 8x8 workgroups over a W x H grid rounded up to multiples of 8. Inside W x H
// each invocation reads 4 times (2 texelFetch + 1 imageLoad = 3 texture reads,
// 1 SSBO load) and writes twice (1 SSBO store, 1 imageStore). Invocations are
// counted on entry, before the bounds check.
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
  ivec2 texSize = ivec2(16, 16);
  vec4 a = texelFetch(source, p % texSize, 0);
  vec4 b = texelFetch(source, (p / 2) % texSize, 0);
  vec4 c = imageLoad(inputImage, p);
  uint index = id.y * size.extent.x + id.x;
  uint v = inputBuffer.values[index];
  outputBuffer.values[index] = v * 3u + uint(a.x * 255.0);
  imageStore(outputImage, p, (a + b + c) * 0.25 + vec4(float(v & 255u) / 255.0));
}
