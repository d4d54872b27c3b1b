// Packed tangent frames (tangent_frame = quaternion; docs/techniques.md,
// "Packed tangent frames"): the 24-bit "smallest three" unit quaternion of
// server/renderers/techniques/tbn.hpp (bit layout there) and the packed vertex. GLSL only;
// included by common.h and mesh.vert.h when TALLY_TBN_QUATERNION is defined.
#ifndef TALLY_SHADERS_TBN_H
#define TALLY_SHADERS_TBN_H

// 24 bytes (std430 and the vertex buffer alike): the frame's 3 bytes sit in
// the low bits of `tbn` (the top byte is 0), the vertex input's R32_UINT.
struct PackedVertex {
  float position[3];
  float uv[2];
  uint tbn;
};

// The unit quaternion (x, y, z, w) of the 24 bits.
vec4 tbnQuaternion(uint bits) {
  uint largest = (bits >> 21u) & 3u;
  float sign = ((bits >> 23u) & 1u) != 0u ? -1.0 : 1.0;
  vec3 c = (vec3(bits & 127u, (bits >> 7u) & 127u, (bits >> 14u) & 127u) / 63.5 - 1.0) * 0.70710678;
  float l = sign * sqrt(max(0.0, 1.0 - dot(c, c)));
  vec4 q = largest == 0u ? vec4(l, c.x, c.y, c.z)
         : largest == 1u ? vec4(c.x, l, c.y, c.z)
         : largest == 2u ? vec4(c.x, c.y, l, c.z)
                         : vec4(c.x, c.y, c.z, l);
  return normalize(q);
}

// Object-space unit normal, and the unit tangent with the bitangent sign in w
// (bit 23: the stored largest component's sign is the handedness).
struct TangentFrame {
  vec3 normal;
  vec4 tangent;
};

TangentFrame decodeTangentFrame(uint bits) {
  vec4 q = tbnQuaternion(bits);
  TangentFrame f;
  f.tangent = vec4(1.0 - 2.0 * (q.y * q.y + q.z * q.z), 2.0 * (q.x * q.y + q.w * q.z),
                   2.0 * (q.x * q.z - q.w * q.y), ((bits >> 23u) & 1u) != 0u ? -1.0 : 1.0);
  f.normal = vec3(2.0 * (q.x * q.z + q.w * q.y), 2.0 * (q.y * q.z - q.w * q.x), 1.0 - 2.0 * (q.x * q.x + q.y * q.y));
  return f;
}

#endif  // TALLY_SHADERS_TBN_H
