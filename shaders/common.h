// GLSL-only helpers of the founding study's passes: resource declarations, the
// surface model (five maps -> Surface), Blinn-Phong, G-buffer encoding, triangle
// fetch and analytic barycentrics. Every renderer shades with the same code, so
// images differ only by what each method stores and reconstructs.
//
// Resources are opt-in: glslang puts every declared resource in the entry
// point's interface even when unused, and each must then be in the pipeline
// layout. Define before #include "common.h":
//   TALLY_LIGHTS     set 0: Lighting UBO, lights SSBO; shade()
//   TALLY_DRAWS      set 2: draws SSBO
//   TALLY_MATERIALS  set 2: materials SSBO
//   TALLY_MESH       set 2: vertices and indices SSBOs; fetchTriangle()
// The camera UBO (set 0) is always declared.
#ifndef TALLY_SHADERS_COMMON_H
#define TALLY_SHADERS_COMMON_H
#include "shared.h"

layout(std140, set = kSetFrame, binding = kBindingCamera) uniform CameraBlock { Camera camera; };

#ifdef TALLY_LIGHTS
layout(std140, set = kSetFrame, binding = kBindingLighting) uniform LightingBlock { Lighting lighting; };
layout(std430, set = kSetFrame, binding = kBindingLights) readonly buffer LightBuffer { PointLight lights[]; };
#endif
#ifdef TALLY_DRAWS
layout(std430, set = kSetGeometry, binding = kBindingDraws) readonly buffer DrawBuffer { DrawData draws[]; };
#endif
#ifdef TALLY_MATERIALS
layout(std430, set = kSetGeometry, binding = kBindingMaterials) readonly buffer MaterialBuffer { Material materials[]; };
#endif
#ifdef TALLY_TBN_QUATERNION
#include "tbn.h"
#define TALLY_VERTEX PackedVertex  // tangent_frame = quaternion: the packed vertex buffer
#else
#define TALLY_VERTEX Vertex
#endif
#ifdef TALLY_MESH
layout(std430, set = kSetGeometry, binding = kBindingVertices) readonly buffer VertexBuffer { TALLY_VERTEX vertices[]; };
layout(std430, set = kSetGeometry, binding = kBindingIndices) readonly buffer IndexBuffer { uint indices[]; };
#if defined(TALLY_VERTEX_COLORS) || defined(TALLY_UV1)
layout(std430, set = kSetGeometry, binding = kBindingVertexAttributes) readonly buffer VertexAttributeBuffer {
  VertexAttributes vertexAttributes[];
};
#endif
#endif
#include "material_features.h"

// ---- Surface ------------------------------------------------------------------
struct Surface {
  vec3 normal;      // world space, unit length
  vec3 diffuse;
  float ambient;    // ambient occlusion: R of the ambient map (glTF occlusion)
  vec3 specular;
  float roughness;  // [0, 1]
};

// The five map texels and the interpolated vertex frame -> Surface. Alpha is
// ignored: alpha testing cannot coexist with early fragment tests.
Surface surfaceFromMaps(vec4 diffuseTexel, vec4 ambientTexel, vec4 specularTexel, vec4 roughnessTexel,
                        vec4 normalTexel, vec3 vertexNormal, vec4 vertexTangent, vec4 baseColor,
                        float roughnessFactor) {
  Surface s;
  vec3 n = normalize(vertexNormal);
  vec3 t = vertexTangent.xyz - n * dot(n, vertexTangent.xyz);  // Gram-Schmidt
  float tLength2 = dot(t, t);
  t *= inversesqrt(max(tLength2, 1e-24));
  mat3 tbn = mat3(t, cross(n, t) * (vertexTangent.w < 0.0 ? -1.0 : 1.0), n);
  // A zero tangent (a loader that made none) keeps the vertex normal.
  s.normal = tLength2 > 1e-12 ? normalize(tbn * (normalTexel.xyz * 2.0 - 1.0)) : n;
  s.diffuse = diffuseTexel.rgb * baseColor.rgb;
  s.ambient = ambientTexel.r;
  s.specular = specularTexel.rgb;
  s.roughness = clamp(roughnessTexel.g * roughnessFactor, 0.0, 1.0);  // glTF: roughness in G
  return s;
}

// G-buffer: RGBA16F normal (w unused), RGBA8 diffuse (a: ambient), RGBA8
// specular (a: roughness). Position is reconstructed from depth.
void encodeGBuffer(Surface s, out vec4 normal, out vec4 diffuse, out vec4 specular) {
  normal = vec4(s.normal, 0.0);
  diffuse = vec4(s.diffuse, s.ambient);
  specular = vec4(s.specular, s.roughness);
}

Surface decodeGBuffer(vec4 normal, vec4 diffuse, vec4 specular) {
  return Surface(normalize(normal.xyz), diffuse.rgb, diffuse.a, specular.rgb, specular.a);
}

// World position of a pixel from its depth ([0, 1], Vulkan NDC).
vec3 worldFromDepth(vec2 fragCoord, float depth) {
  vec4 h = camera.invViewProj * vec4(fragCoord * camera.viewport.zw * 2.0 - 1.0, depth, 1.0);
  return h.xyz / h.w;
}

// ---- Analytic barycentrics ------------------------------------------------------
// Perspective-correct barycentrics of the pixel centre fragCoord in the triangle
// with clip positions c0..c2, and their change across one pixel in x and y
// (Schied & Dachsbacher 2015; Burns & Hunt 2013). lambda/w is affine in NDC.
struct Barycentrics {
  vec3 lambda;
  vec3 ddx;
  vec3 ddy;
};

Barycentrics barycentricsFromClip(vec4 c0, vec4 c1, vec4 c2, vec2 fragCoord) {
  Barycentrics b;
  vec3 invW = 1.0 / vec3(c0.w, c1.w, c2.w);
  vec2 n0 = c0.xy * invW.x, n1 = c1.xy * invW.y, n2 = c2.xy * invW.z;
  float invDet = 1.0 / determinant(mat2(n2 - n1, n0 - n1));
  vec3 gradX = vec3(n1.y - n2.y, n2.y - n0.y, n0.y - n1.y) * invDet * invW;  // d(lambda/w)/d(ndc.x)
  vec3 gradY = vec3(n2.x - n1.x, n0.x - n2.x, n1.x - n0.x) * invDet * invW;
  vec2 d = fragCoord * camera.viewport.zw * 2.0 - 1.0 - n0;
  vec3 overW = vec3(invW.x, 0.0, 0.0) + d.x * gradX + d.y * gradY;  // lambda / w at the pixel
  float sumOverW = overW.x + overW.y + overW.z;                      // 1 / w at the pixel
  b.lambda = overW / sumOverW;
  vec3 stepX = gradX * (2.0 * camera.viewport.z);  // one pixel in NDC
  vec3 stepY = gradY * (2.0 * camera.viewport.w);
  b.ddx = (overW + stepX) / (sumOverW + stepX.x + stepX.y + stepX.z) - b.lambda;
  b.ddy = (overW + stepY) / (sumOverW + stepY.x + stepY.y + stepY.z) - b.lambda;
  return b;
}

vec3 toVec3(float v[3]) { return vec3(v[0], v[1], v[2]); }
vec2 uvOf(Vertex v) { return vec2(v.uv[0], v.uv[1]); }

// Vertex attributes at barycentrics b, position and frame in world space.
struct Interpolated {
  vec3 position;
  vec3 normal;
  vec4 tangent;
  vec2 uv;
};

Interpolated interpolateVertices(Vertex v0, Vertex v1, Vertex v2, vec3 b, mat4 model) {
  Interpolated a;
  vec3 p = toVec3(v0.position) * b.x + toVec3(v1.position) * b.y + toVec3(v2.position) * b.z;
  a.position = (model * vec4(p, 1.0)).xyz;
  a.normal = mat3(model) * (toVec3(v0.normal) * b.x + toVec3(v1.normal) * b.y + toVec3(v2.normal) * b.z);
  vec4 t = vec4(v0.tangent[0], v0.tangent[1], v0.tangent[2], v0.tangent[3]) * b.x +
           vec4(v1.tangent[0], v1.tangent[1], v1.tangent[2], v1.tangent[3]) * b.y +
           vec4(v2.tangent[0], v2.tangent[1], v2.tangent[2], v2.tangent[3]) * b.z;
  a.tangent = vec4(mat3(model) * t.xyz, v0.tangent[3]);  // handedness is per triangle
  a.uv = uvOf(v0) * b.x + uvOf(v1) * b.y + uvOf(v2) * b.z;
  return a;
}

#ifdef TALLY_TBN_QUATERNION
vec2 uvOf(PackedVertex v) { return vec2(v.uv[0], v.uv[1]); }
Vertex unpackVertex(PackedVertex p) {
  TangentFrame f = decodeTangentFrame(p.tbn);
  return Vertex(p.position, float[3](f.normal.x, f.normal.y, f.normal.z),
                float[4](f.tangent.x, f.tangent.y, f.tangent.z, f.tangent.w), p.uv);
}
Interpolated interpolateVertices(PackedVertex p0, PackedVertex p1, PackedVertex p2, vec3 b, mat4 model) {
  return interpolateVertices(unpackVertex(p0), unpackVertex(p1), unpackVertex(p2), b, model);
}
#endif

#ifdef TALLY_MESH
// Vertex ids of triangle `triangle` (gl_PrimitiveID) of a draw.
uvec3 fetchTriangle(uint firstIndex, int vertexOffset, uint triangle) {
  uint base = firstIndex + 3u * triangle;
  return uvec3(ivec3(indices[base], indices[base + 1u], indices[base + 2u]) + vertexOffset);
}
#endif

// ---- Blinn-Phong ------------------------------------------------------------------
float shininessFromRoughness(float roughness) {
  float a2 = roughness * roughness * roughness * roughness;  // alpha = roughness^2
  return clamp(2.0 / max(a2, 1e-6) - 2.0, 1.0, kMaxShininess);
}

// Smooth window to zero at the radius, inverse-square inside (d in m).
float attenuation(float d, float radius) {
  float x = clamp(1.0 - pow(d / radius, 4.0), 0.0, 1.0);
  return x * x / (d * d + 1.0);
}

#ifdef TALLY_LIGHTS
#ifdef TALLY_SHADOWS
#include "shadow.h"
#endif
vec3 shade(Surface s, vec3 position) {
  vec3 v = normalize(camera.position.xyz - position);
  float shininess = shininessFromRoughness(s.roughness);
  vec3 color = lighting.ambient * s.ambient * s.diffuse;
#ifdef TALLY_SHADOWS
  color += sunTerm(s, position, v, shininess);  // the shadowed sun (shadow.h)
#endif
  uint count = min(lighting.lightCount, kMaxLights);
  for (uint i = 0u; i < count; ++i) {
    PointLight light = lights[i];
    vec3 toLight = light.positionRadius.xyz - position;
    float d = length(toLight);
    float falloff = attenuation(d, light.positionRadius.w);
    vec3 l = toLight / max(d, 1e-4);
    float nDotL = dot(s.normal, l);
    if (falloff <= 0.0 || nDotL <= 0.0) continue;
    float nDotH = max(dot(s.normal, normalize(l + v)), 0.0);
    color += light.color.rgb * falloff * (s.diffuse * nDotL + s.specular * pow(nDotH, shininess));
  }
  return color;
}
#endif

#endif  // TALLY_SHADERS_COMMON_H
