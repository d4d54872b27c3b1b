// The compute workloads' shared GLSL (renderers/workloads/workloads.hpp): the camera,
// the "hdr" storage image every pixel is written to, and the primary ray.
#ifndef TALLY_SHADERS_WORKLOAD_H
#define TALLY_SHADERS_WORKLOAD_H
#include "shared.h"

layout(local_size_x = 8, local_size_y = 8) in;
layout(std140, set = kSetFrame, binding = kBindingCamera) uniform CameraBlock { Camera camera; };
layout(set = kSetPassInput, binding = 0, rgba16f) uniform writeonly image2D hdrOut;

// Through pixel `px`'s centre: view-space (ndc.x / proj[0][0], ndc.y /
// proj[1][1], -1), normalised, to world (workloadRayDirection on the CPU).
vec3 primaryRay(uvec2 px) {
  vec2 ndc = (vec2(px) + 0.5) * camera.viewport.zw * 2.0 - 1.0;
  vec3 v = vec3(ndc.x / camera.proj[0][0], ndc.y / camera.proj[1][1], -1.0);
  return normalize(transpose(mat3(camera.view)) * v);
}

vec3 skyColour(vec3 d) { return mix(vec3(0.55, 0.6, 0.7), vec3(0.15, 0.25, 0.5), clamp(d.y * 0.5 + 0.5, 0.0, 1.0)); }

#endif
