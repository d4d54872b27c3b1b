#version 450
// mixed_reads' bindings; every in-bounds invocation runs loops of each shape
// the accumulate mode derives from trip counters (docs/measurement.md, "Sites
// in loops"), each loading inputBuffer. Loads per invocation, with
// index = y * W + x (loopShapeLoads in accumulate_loops_test.cpp adds them):
//  - constant bound, 2 loads x 5;                   - a bound read from the
//    push constants (W % 7), 1 load x (W % 7);      - a bound below the
//    start (signed, 4 < x % 3: never), 0;           - step 2 (1..9), 5;
//  - counted from 5 to W % 7 (none where W % 7 <= 5): max(0, W % 7 - 5);
//  - a bound read from the buffer before the loop (values[i] = 7i + 1):
//    1 + (7 index + 1) % 4;
//  - <= from -3 to 2 (signed), 2 loads x 6;         - down by 1 (8 > 2), 6;
//  - down by 3 with >= (10, 7, 4, 1), 4;            - != 4, 4;
//  - while (k > 0) k >>= 1 from index: its bit length, 2 loads each;
//  - do-while, at least once: max(1, index & 3) x 2 loads;
//  - break at i == index % 4 of 6: (index % 4 + 1) loads before it, index % 4 after;
//  - continue on even i of 6: 6 loads before it, 3 after;
//  - nested: 3 outer (1 load each) x i inner (2 loads each): 3 + 2 x 3;
//    and W % 7 outer (1 load) x 3 inner (2 loads): 7 x (W % 7);
//  - in a called function, 2 loads per trip, called with 3 and index % 5 trips.
// The buffer write once; invocations ceil(W/8)*8 x ceil(H/8)*8.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2D source;
layout(set = 0, binding = 1, rgba8) uniform readonly image2D inputImage;
layout(set = 0, binding = 2) readonly buffer Input { uint values[]; } inputBuffer;
layout(set = 0, binding = 3) writeonly buffer Output { uint values[]; } outputBuffer;
layout(set = 0, binding = 4, rgba8) uniform writeonly image2D outputImage;

layout(push_constant) uniform Size { uvec2 extent; } size;

uint n;

uint at(uint i) { return inputBuffer.values[i % n]; }

uint inFunction(uint base, uint trips) {
  uint s = 0u;
  for (uint i = 0u; i < trips; ++i) s += at(base + i) ^ inputBuffer.values[(base + 2u * i) % n];
  return s;
}

void main() {
  uvec2 id = gl_GlobalInvocationID.xy;
  if (id.x >= size.extent.x || id.y >= size.extent.y) return;
  n = size.extent.x * size.extent.y;
  uint index = id.y * size.extent.x + id.x;
  uint s = 0u;
  for (uint i = 0u; i < 5u; ++i) s += inputBuffer.values[(index + i) % n] * inputBuffer.values[(index + 3u * i) % n];
  uint pushed = size.extent.x % 7u;
  for (uint i = 0u; i < pushed; ++i) s += inputBuffer.values[(index * 3u + i) % n];
  for (uint i = 0u; i < pushed; ++i) {
    s += inputBuffer.values[(index + 17u * i) % n];
    for (int k = 0; k < 3; ++k) s += inputBuffer.values[(index + uint(k)) % n] & inputBuffer.values[(i + uint(k)) % n];
  }
  for (int i = 4; i < int(id.x % 3u); ++i) s += inputBuffer.values[(index + uint(i)) % n];
  for (uint i = 5u; i < pushed; ++i) s += inputBuffer.values[(index + 2u * i) % n];
  uint fromBuffer = inputBuffer.values[index % n] % 4u;
  for (uint i = 0u; i < fromBuffer; ++i) s += inputBuffer.values[(index + 19u * i) % n];
  for (uint i = 1u; i < 10u; i += 2u) s ^= inputBuffer.values[(index + i) % n];
  for (int i = -3; i <= 2; ++i) s += inputBuffer.values[(index + uint(i + 3)) % n] - inputBuffer.values[(index + 7u) % n];
  for (uint i = 8u; i > 2u; --i) s += inputBuffer.values[(index * i) % n];
  for (int i = 10; i >= 0; i -= 3) s += inputBuffer.values[(index + uint(i)) % n];
  for (uint i = 0u; i != 4u; ++i) s ^= inputBuffer.values[(index + 5u * i) % n];
  for (uint k = index; k > 0u; k >>= 1) s += inputBuffer.values[k % n] + inputBuffer.values[(k * 5u) % n];
  uint j = 0u;
  do {
    s += inputBuffer.values[(index + j) % n] | inputBuffer.values[(index + j + 9u) % n];
    ++j;
  } while (j < (index & 3u));
  for (uint i = 0u; i < 6u; ++i) {
    s += inputBuffer.values[(index + i) % n];
    if (i == index % 4u) break;
    s += inputBuffer.values[(index + 11u * i) % n];
  }
  for (uint i = 0u; i < 6u; ++i) {
    s += inputBuffer.values[(index ^ i) % n];
    if ((i & 1u) == 0u) continue;
    s += inputBuffer.values[(index + 13u * i) % n];
  }
  for (uint i = 0u; i < 3u; ++i) {
    s += inputBuffer.values[(index + i) % n];
    for (uint k = 0u; k < i; ++k) s += inputBuffer.values[(index + k) % n] * inputBuffer.values[(index + i + k) % n];
  }
  s += inFunction(index, 3u) + inFunction(index + 1u, index % 5u);
  outputBuffer.values[index] = s;
}
