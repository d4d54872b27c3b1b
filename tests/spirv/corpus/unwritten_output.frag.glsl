#version 450
// An output that is declared but never written still gets an output_write
// (the attachment is written anyway); an early return gives main two OpReturns.
layout(set = 3, binding = 0) uniform Fade {
  vec4 color;
  float threshold;
} fade;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;
layout(location = 1) out vec4 outUnused;

void main() {
  if (inUv.x > fade.threshold) {
    outColor = vec4(0.0);
    return;
  }
  outColor = fade.color;
}
