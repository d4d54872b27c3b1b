#version 450
// Uses set 7 binding 0, which the counters need: instrument() must refuse it.
layout(std430, set = 7, binding = 0) buffer Reserved {
  uint values[];
} reserved;
layout(set = 0, binding = 0) uniform sampler2D albedo;

layout(location = 0) in vec2 inUv;
layout(location = 0) out vec4 outColor;

void main() {
  outColor = texture(albedo, inUv) * float(reserved.values[0]);
}
