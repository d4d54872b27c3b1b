#version 460
#extension GL_GOOGLE_include_directive : require
// Volume fog (docs/techniques.md, "Volume fog"; renderers/workloads/workloads.cpp): per
// pixel a ray through the scene's bounding box, fogSteps samples between its
// entry and exit, each the fractal sum of `n` octaves of the tiled 3D density
// texture (one texture() per octave, doubling frequency, halving amplitude;
// octaves not read add their mean), composited front to back, stopped once the
// opacity reaches the termination threshold. n per sample:
//   default       fog.counts.y, a uniform: a loop the compiler cannot unroll
//   FOG_DYNAMIC   clamp(max - floor(log2(t / t0)), 1, max): a bound from distance
//   FOG_CONSTANT  FOG_MAX_OCTAVES, a compile-time constant: unrollable
// Alpha of "hdr" = the samples marched (0: the ray missed the box).
#include "workload.h"

layout(set = kSetPassInput, binding = 1) uniform sampler3D fogDensity;  // R8_UNORM, REPEAT
layout(std140, set = kSetPassInput, binding = 2) uniform FogBlock {
  vec4 boxMin;   // w: tile size (world size of octave 0's repetition)
  vec4 boxMax;   // w: t0
  vec4 params;   // x: extinction per metre at density 1, y: termination opacity
  uvec4 counts;  // x: steps, y: max octaves
} fog;

void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= uint(camera.viewport.x) || px.y >= uint(camera.viewport.y)) return;
  vec3 o = camera.position.xyz;
  vec3 d = primaryRay(px);
  const vec3 boxMin = fog.boxMin.xyz, boxMax = fog.boxMax.xyz;
  const float tile = fog.boxMin.w, t0 = fog.boxMax.w;
  const float sigmaScale = fog.params.x, threshold = fog.params.y;
  const uint steps = fog.counts.x, maxOctaves = fog.counts.y;
  vec3 inv = 1.0 / d;
  vec3 ta = (boxMin - o) * inv, tb = (boxMax - o) * inv;
  vec3 tn = min(ta, tb), tf = max(ta, tb);
  float tEnter = max(max(max(tn.x, tn.y), tn.z), 0.0);
  float tExit = min(min(tf.x, tf.y), tf.z);
  // Sum of the amplitudes of maxOctaves octaves: 2 (1 - 2^-max).
  const float total = 2.0 * (1.0 - exp2(-float(maxOctaves)));
  vec3 colour = vec3(0.0);
  float transmittance = 1.0;
  uint marched = 0u;
  if (tExit > tEnter) {
    float dt = (tExit - tEnter) / float(steps);
    for (uint i = 0u; i < steps; ++i) {
      float t = tEnter + (float(i) + 0.5) * dt;
      vec3 p = o + d * t;
      vec3 uvw = (p - boxMin) / tile;
#if defined(FOG_CONSTANT)
      const uint n = FOG_MAX_OCTAVES;
#elif defined(FOG_DYNAMIC)
      uint n = uint(clamp(int(maxOctaves) - int(floor(log2(t / t0))), 1, int(maxOctaves)));
#else
      uint n = maxOctaves;
#endif
      float sum = 0.0, amplitude = 1.0, frequency = 1.0;
      for (uint k = 0u; k < n; ++k) {
        sum += amplitude * texture(fogDensity, uvw * frequency).r;
        amplitude *= 0.5;
        frequency *= 2.0;
      }
      sum += 0.5 * (total - 2.0 * (1.0 - exp2(-float(n))));  // the unread octaves' mean
      float density = sum / total;
      float alpha = 1.0 - exp(-sigmaScale * density * dt);
      float height = clamp((p.y - boxMin.y) / max(boxMax.y - boxMin.y, 1e-6), 0.0, 1.0);
      vec3 lit = mix(vec3(0.55, 0.6, 0.68), vec3(1.2, 1.1, 0.95), height) * (0.6 + 0.8 * density);
      colour += transmittance * alpha * lit;
      transmittance *= 1.0 - alpha;
      marched = i + 1u;
      if (1.0 - transmittance >= threshold) break;
    }
  }
  colour += transmittance * skyColour(d);
  imageStore(hdrOut, ivec2(px), vec4(colour, float(marched)));
}
