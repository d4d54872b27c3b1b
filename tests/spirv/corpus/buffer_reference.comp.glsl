#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// Device addresses (PhysicalStorageBuffer): set/binding -1, resource physical_storage_buffer.
// The address comes from a push constant (not counted).
layout(local_size_x = 64) in;

layout(buffer_reference, std430, buffer_reference_align = 16) buffer Particles {
  vec4 positions[];
};
layout(buffer_reference, std430, buffer_reference_align = 4) buffer Velocities {
  vec4 velocities[];
};

layout(push_constant) uniform Push {
  Particles particles;
  Velocities velocities;
  float dt;
} pc;

void main() {
  uint i = gl_GlobalInvocationID.x;
  vec4 v = pc.velocities.velocities[i];
  pc.particles.positions[i] += v * pc.dt;
}
