#version 460
#extension GL_GOOGLE_include_directive : require
// Fat visibility buffer, pass 1, for devices without fragment-shader
// barycentrics: ids, barycentrics and uv derivatives of the visible triangle.
// The barycentrics come from the triangle's three vertices, fetched from the
// index/vertex buffers by gl_PrimitiveID and projected again (3 indices, 3
// positions and the model matrix per fragment: buffer traffic that
// visibility_bary.frag does not have). gl_PrimitiveID in a fragment shader
// needs the Geometry capability (geometryShader; lavapipe and NVIDIA have it).
#define TALLY_DRAWS
#define TALLY_MESH
#include "alpha_test_stage.h"  // early tests, or the alpha test of MASK draws
#include "common.h"
#include "visibility_encoding.h"


layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = 0) in vec2 inUv;

layout(location = kOutVisibility) out VisibilityTexel outVisibility;           // id, barycentrics
layout(location = kOutUvDerivatives) out UvDerivativeTexel outUvDerivatives;  // dFdx(uv), dFdy(uv)

void main() {
  ALPHA_TEST(push.materialIndex);  // alphaMode MASK draws (alpha_test_stage.h)
  uint triangle = uint(gl_PrimitiveID);
  uvec3 v = fetchTriangle(draws[push.drawIndex].firstIndex, draws[push.drawIndex].vertexOffset, triangle);
  mat4 clipFromObject = camera.viewProj * draws[push.drawIndex].model;
  Barycentrics b = barycentricsFromClip(clipFromObject * vec4(toVec3(vertices[v.x].position), 1.0),
                                        clipFromObject * vec4(toVec3(vertices[v.y].position), 1.0),
                                        clipFromObject * vec4(toVec3(vertices[v.z].position), 1.0),
                                        gl_FragCoord.xy);
  outVisibility = encodeVisibility(packVisibilityId(push.drawIndex, triangle), b.lambda.yz);
  outUvDerivatives = encodeUvDerivatives(dFdx(inUv), dFdy(inUv));
}
