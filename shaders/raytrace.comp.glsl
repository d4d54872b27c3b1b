#version 460
#extension GL_GOOGLE_include_directive : require
// A small compute ray tracer (docs/techniques.md, "Ray tracer";
// renderers/workloads/workloads.cpp): spheres from a storage buffer on a ground plane,
// one point light. Per pixel a primary ray; per hit one shadow ray to the
// light and, up to `bounces` times, a specular reflection ray. Every ray tests
// every sphere (one vec4 read each); diffuse + Blinn-Phong specular shading.
// Alpha of "hdr" = shadow rays x 8 + reflection rays of the pixel.
#include "workload.h"

layout(std430, set = kSetPassInput, binding = 1) readonly buffer SphereBuffer { vec4 spheres[]; };  // xyz, radius
layout(std140, set = kSetPassInput, binding = 2) uniform RayBlock {
  vec4 light;    // xyz: position; w: ground plane y
  vec4 params;   // x: epsilon
  uvec4 counts;  // x: spheres, y: bounces
} rt;

const uint kNone = 0xffffffffu;

// The nearest sphere hit in (eps, tMax) along o + t d (d unit), or kNone;
// `sphere` its centre and radius (kept, so that no ray reads a sphere twice).
float traceSpheres(vec3 o, vec3 d, float tMax, float eps, uint count, out uint hit, out vec4 sphere) {
  float best = tMax;
  hit = kNone;
  sphere = vec4(0.0);
  for (uint i = 0u; i < count; ++i) {
    vec4 s = spheres[i];
    vec3 oc = o - s.xyz;
    float b = dot(oc, d);
    float c = dot(oc, oc) - s.w * s.w;
    float h = b * b - c;
    if (h > 0.0) {
      float t = -b - sqrt(h);
      if (t > eps && t < best) {
        best = t;
        hit = i;
        sphere = s;
      }
    }
  }
  return best;
}

vec3 sphereAlbedo(uint i) {
  uint h = i * 2654435761u;
  return vec3(float((h >> 8) & 255u), float((h >> 16) & 255u), float((h >> 24) & 255u)) / 255.0 * 0.8 + 0.1;
}

void main() {
  uvec2 px = gl_GlobalInvocationID.xy;
  if (px.x >= uint(camera.viewport.x) || px.y >= uint(camera.viewport.y)) return;
  const uint count = rt.counts.x, bounces = rt.counts.y;
  const float eps = rt.params.x, groundY = rt.light.w;
  const vec3 lightPos = rt.light.xyz;
  vec3 o = camera.position.xyz;
  vec3 d = primaryRay(px);
  vec3 colour = vec3(0.0), weight = vec3(1.0);
  uint shadowRays = 0u, reflectionRays = 0u;
  for (uint bounce = 0u;; ++bounce) {
    uint index;
    vec4 s;
    float t = traceSpheres(o, d, 1e30, eps, count, index, s);
    float tg = d.y < 0.0 ? (groundY - o.y) / d.y : 1e30;
    bool ground = tg > eps && tg < t;
    if (index == kNone && !ground) {
      colour += weight * skyColour(d);
      break;
    }
    vec3 p, n, albedo;
    float reflectivity;
    if (ground) {
      p = o + d * tg;
      n = vec3(0.0, 1.0, 0.0);
      albedo = vec3(0.45, 0.42, 0.38);
      reflectivity = 0.25;
    } else {
      p = o + d * t;
      n = (p - s.xyz) / s.w;
      albedo = sphereAlbedo(index);
      reflectivity = 0.6;
    }
    vec3 toLight = lightPos - p;
    float dist = length(toLight);
    vec3 l = toLight / dist;
    vec3 q = p + n * eps;
    uint blocker;
    vec4 unused;
    traceSpheres(q, l, dist, eps, count, blocker, unused);
    ++shadowRays;
    float visible = blocker == kNone ? 1.0 : 0.0;
    float ndl = max(dot(n, l), 0.0);
    vec3 h = normalize(l - d);
    float specular = pow(max(dot(n, h), 0.0), 48.0);
    colour += weight * (albedo * (0.12 + visible * ndl * 1.5) + visible * specular * 0.8);
    if (bounce >= bounces) break;
    d = reflect(d, n);
    o = q;
    weight *= reflectivity;
    ++reflectionRays;
  }
  imageStore(hdrOut, ivec2(px), vec4(colour, float(shadowRays * 8u + reflectionRays)));
}
