#version 460
#extension GL_GOOGLE_include_directive : require
#ifdef TALLY_ALPHA_TEST
#define TALLY_MATERIALS  // alpha_test.h reads the material
#endif
// Fat visibility buffer, pass 1, for devices without fragment-shader
// barycentrics: ids, barycentrics and uv derivatives of the visible triangle.
// The barycentrics come from the triangle's three vertices, fetched from the
// index/vertex buffers by gl_PrimitiveID and projected again (3 indices, 3
// positions and the model matrix per fragment: buffer traffic that
// visibility_bary.frag does not have). gl_PrimitiveID in a fragment shader
// needs the Geometry capability (geometryShader; lavapipe and NVIDIA have it).
#define TALLY_DRAWS
#define TALLY_MESH
#include "common.h"
#include "visibility_encoding.h"

#ifdef TALLY_ALPHA_TEST
// alphaMode MASK draws (alpha_test.h): the test decides coverage, so no early tests.
#include "common.h"
#include "alpha_test.h"
#else
layout(early_fragment_tests) in;
#endif

layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = 0) in vec2 inUv;

layout(location = kOutVisibility) out VisibilityTexel outVisibility;           // id, barycentrics
layout(location = kOutUvDerivatives) out UvDerivativeTexel outUvDerivatives;  // dFdx(uv), dFdy(uv)

void main() {
#ifdef TALLY_ALPHA_TEST
  alphaTest(push.materialIndex);
#endif
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
