#version 450
// SSBO atomics (buffer_write only) and imageAtomicAdd on an r32ui image (image_atomic).
layout(local_size_x = 8, local_size_y = 8) in;

layout(std430, set = 0, binding = 0) buffer Counters {
  uint total;
  uint maxValue;
  int signedMin;
} counters;
layout(set = 1, binding = 0, r32ui) uniform uimage2D histogramImage;
layout(set = 1, binding = 1) uniform sampler2D inputTex;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  vec4 c = texelFetch(inputTex, p, 0);
  uint bucket = uint(clamp(c.r, 0.0, 1.0) * 255.0);
  atomicAdd(counters.total, 1u);
  atomicMax(counters.maxValue, bucket);
  atomicMin(counters.signedMin, int(bucket) - 128);
  imageAtomicAdd(histogramImage, ivec2(int(bucket), 0), 1u);
}
