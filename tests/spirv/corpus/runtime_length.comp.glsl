#version 450
// .length() of runtime arrays only (OpArrayLength, not counted) and a store; a push constant.
layout(local_size_x = 1) in;

layout(std430, set = 3, binding = 0) readonly buffer Items {
  vec4 items[];
} itemBuffer;
layout(std430, set = 3, binding = 1) writeonly buffer Result {
  uint itemCount;
  uint multiplied;
} result;
layout(push_constant) uniform Push {
  uint factor;
} pc;

void main() {
  uint n = uint(itemBuffer.items.length());
  result.itemCount = n;
  result.multiplied = n * pc.factor;
}
