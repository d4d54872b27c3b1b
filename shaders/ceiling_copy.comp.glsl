#version 460
#extension GL_EXT_control_flow_attributes : require
// Device ceilings (server/gpu/ceilings.hpp): the achievable memory bandwidth.
// A streaming copy of uvec4 (16-byte) elements from one buffer to another.
// Each invocation copies kPerInvocation elements, a dispatch's width apart,
// so that consecutive invocations always touch consecutive elements (what a
// GPU's memory system wants) while the cost of an invocation (large on a CPU
// implementation such as lavapipe) is shared by several copies.
#define kPerInvocation 4
layout(local_size_x = 256) in;
layout(std430, set = 0, binding = 0) readonly buffer Source { uvec4 source[]; };
layout(std430, set = 0, binding = 1) writeonly buffer Destination { uvec4 destination[]; };
layout(push_constant) uniform Push {
  uint elements;  // uvec4 elements in each buffer
  uint stride;    // invocations in the dispatch
} push;

void main() {
  const uint first = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x;
  [[unroll]] for (uint k = 0u; k < kPerInvocation; ++k) {
    const uint i = first + k * push.stride;
    if (i < push.elements) destination[i] = source[i];
  }
}
