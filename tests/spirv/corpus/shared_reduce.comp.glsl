#version 450
// Shared memory reduction (shared memory is not counted); one SSBO read, one SSBO write.
layout(local_size_x = 128) in;

layout(std430, set = 2, binding = 0) readonly buffer Input {
  float values[];
} inputData;
layout(std430, set = 2, binding = 1) writeonly buffer Output {
  float sums[];
} outputData;

shared float partial[128];

void main() {
  uint lid = gl_LocalInvocationID.x;
  partial[lid] = inputData.values[gl_GlobalInvocationID.x];
  barrier();
  for (uint stride = 64u; stride > 0u; stride >>= 1u) {
    if (lid < stride) {
      partial[lid] += partial[lid + stride];
    }
    barrier();
  }
  if (lid == 0u) {
    outputData.sums[gl_WorkGroupID.x] = partial[0];
  }
}
