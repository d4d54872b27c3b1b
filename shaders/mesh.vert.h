// Vertex stage shared by forward.vert and gbuffer.vert: one body, so both
// renderers (and zprepass.vert, via `invariant`) rasterise identical positions.
#define TALLY_DRAWS
#include "common.h"

layout(location = kAttribPosition) in vec3 inPosition;
#ifdef TALLY_TBN_QUATERNION
layout(location = kAttribNormal) in uint inTbn;  // R32_UINT: the 24-bit frame (tbn.h)
#else
layout(location = kAttribNormal) in vec3 inNormal;
layout(location = kAttribTangent) in vec4 inTangent;
#endif
layout(location = kAttribUv) in vec2 inUv;
#ifdef TALLY_VERTEX_COLORS
layout(location = kAttribColor) in vec4 inColor;  // COLOR_0 (vertex buffer 1)
layout(location = 4) out vec4 outColor;
#endif
#ifdef TALLY_UV1
layout(location = kAttribUv1) in vec2 inUv1;  // TEXCOORD_1 (vertex buffer 1)
layout(location = 5) out vec2 outUv1;
#endif

layout(push_constant) uniform PushBlock { DrawPush push; };

layout(location = 0) out vec3 outPosition;  // world space (m)
layout(location = 1) out vec3 outNormal;
layout(location = 2) out vec4 outTangent;
layout(location = 3) out vec2 outUv;

invariant gl_Position;

void main() {
#ifdef TALLY_TBN_QUATERNION
  TangentFrame frame = decodeTangentFrame(inTbn);
  vec3 inNormal = frame.normal;
  vec4 inTangent = frame.tangent;
#endif
  mat4 model = draws[push.drawIndex].model;
  vec4 world = model * vec4(inPosition, 1.0);
  gl_Position = camera.viewProj * world;
  outPosition = world.xyz;
  outNormal = mat3(model) * inNormal;  // DrawData::model has uniform scale
  outTangent = vec4(mat3(model) * inTangent.xyz, inTangent.w);
  outUv = inUv;
#ifdef TALLY_VERTEX_COLORS
  outColor = inColor;
#endif
#ifdef TALLY_UV1
  outUv1 = inUv1;
#endif
}
