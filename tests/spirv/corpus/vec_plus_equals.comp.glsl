#version 450
// An SSBO array of structs with a vec member updated with += (read and write).
layout(local_size_x = 64) in;

struct Particle {
  vec4 position;
  vec4 velocity;
  float life;
  float pad0;
  float pad1;
  float pad2;
};

layout(std430, set = 0, binding = 3) buffer ParticleBuffer {
  Particle particles[];
};
layout(set = 0, binding = 4) uniform Sim {
  vec4 gravity;
  float dt;
} sim;

void main() {
  uint i = gl_GlobalInvocationID.x;
  particles[i].velocity += sim.gravity * sim.dt;
  particles[i].position.xyz += particles[i].velocity.xyz * sim.dt;
  particles[i].life -= sim.dt;
}
