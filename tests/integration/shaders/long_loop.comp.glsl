#version 450
// mixed_reads' bindings; each in-bounds invocation loads 70008 buffer
// elements, more than the 16 bits an accumulate-mode flush adds in each half
// (70008 = 0x11178: both halves non-zero): 4 loads in each of 17502 loop
// iterations, because llvmpipe stops an invocation's loops after 65535
// iterations in all (found here: a loop of 70001 counted 65535 in every
// mode, and two nested loops of 7 x 10001 stopped near 65535 too).
// Counts at W x H: buffer reads W*H*70008, buffer writes W*H, invocations
// ceil(W/8)*8 x ceil(H/8)*8.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D source;
layout(set = 0, binding = 1, rgba8) uniform readonly image2D inputImage;
layout(set = 0, binding = 2) readonly buffer Input { uint values[]; } inputBuffer;
layout(set = 0, binding = 3) writeonly buffer Output { uint values[]; } outputBuffer;
layout(set = 0, binding = 4, rgba8) uniform writeonly image2D outputImage;

layout(push_constant) uniform Size { uvec2 extent; } size;

const uint kIterations = 17502u;  // x 4 loads = 70008

void main() {
  uvec2 id = gl_GlobalInvocationID.xy;
  if (id.x >= size.extent.x || id.y >= size.extent.y) return;
  uint n = size.extent.x * size.extent.y;
  uint index = id.y * size.extent.x + id.x;
  uint sum = 0u;
  for (uint i = 0u; i < kIterations; ++i) {
    uint at = index + 4u * i;
    sum += inputBuffer.values[at % n] + inputBuffer.values[(at + 1u) % n] + inputBuffer.values[(at + 2u) % n] +
           inputBuffer.values[(at + 3u) % n];
  }
  outputBuffer.values[index] = sum;
}
