#version 450
// Shared-memory atomics (not counted) then SSBO atomics (buffer_write only); imageLoad on a storage image.
layout(local_size_x = 16, local_size_y = 16) in;

layout(set = 2, binding = 2, rgba8) uniform readonly image2D luminanceImage;
layout(std430, set = 2, binding = 3) buffer Histogram {
  uint bins[256];
} histogram;

shared uint localBins[256];

void main() {
  uint lid = gl_LocalInvocationIndex;
  localBins[lid] = 0u;
  barrier();
  vec4 c = imageLoad(luminanceImage, ivec2(gl_GlobalInvocationID.xy));
  uint bin = uint(clamp(dot(c.rgb, vec3(0.2126, 0.7152, 0.0722)), 0.0, 1.0) * 255.0);
  atomicAdd(localBins[bin], 1u);
  barrier();
  atomicAdd(histogram.bins[lid], localBins[lid]);
}
