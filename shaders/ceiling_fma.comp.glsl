#version 460
// Device ceilings (server/gpu/ceilings.hpp): the peak arithmetic rate. Eight
// independent vec4 multiply-add chains per invocation (kChains x 4 components
// x 2 operations = 64 per iteration), long enough to hide each chain's
// latency behind the others. The multiplier and addend come from push
// constants and the start from the invocation id, and every chain ends in one
// store, so no compiler can fold or drop the work. a * b + c, not fma(): a
// driver may contract it into one instruction, while fma() forces the fused
// form, which a CPU without FMA units emulates slowly.
layout(local_size_x = 256) in;
layout(std430, set = 0, binding = 0) writeonly buffer Result { vec4 result[]; };
layout(push_constant) uniform Push {
  uint iterations;
  float multiplier;  // just under 1: the chains converge, never overflow
  float addend;
} push;

void main() {
  const float seed = float(gl_GlobalInvocationID.x & 1023u) * 1e-3;
  vec4 a0 = vec4(seed, seed + 0.1, seed + 0.2, seed + 0.3);
  vec4 a1 = a0 + 1.0, a2 = a0 + 2.0, a3 = a0 + 3.0, a4 = a0 + 4.0, a5 = a0 + 5.0, a6 = a0 + 6.0, a7 = a0 + 7.0;
  const vec4 b = vec4(push.multiplier), c = vec4(push.addend);
  for (uint i = 0u; i < push.iterations; ++i) {
    a0 = a0 * b + c; a1 = a1 * b + c; a2 = a2 * b + c; a3 = a3 * b + c;
    a4 = a4 * b + c; a5 = a5 * b + c; a6 = a6 * b + c; a7 = a7 * b + c;
  }
  result[gl_GlobalInvocationID.x] = ((a0 + a1) + (a2 + a3)) + ((a4 + a5) + (a6 + a7));
}
