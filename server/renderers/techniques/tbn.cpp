#include "renderers/techniques/tbn.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "renderers/gpu_scene.hpp"
#include "shared.h"

namespace tally::renderers {
namespace {

constexpr double kSqrt2 = 1.4142135623730951;

// q as (x, y, z, w).
using Quat = glm::dvec4;

glm::dvec3 anyOrthogonal(glm::dvec3 n) {
  glm::dvec3 a = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  return glm::normalize(a - n * glm::dot(n, a));
}

// The orthonormal frame (unit n, unit t orthogonal to it) of a vertex.
void orthonormalise(glm::vec3 normal, glm::vec4 tangent, glm::dvec3& n, glm::dvec3& t) {
  n = glm::dvec3(normal);
  double nl = glm::length(n);
  n = nl > 1e-12 && std::isfinite(nl) ? n / nl : glm::dvec3(0, 0, 1);
  t = glm::dvec3(tangent);
  t -= n * glm::dot(n, t);
  double tl = glm::length(t);
  t = tl > 1e-9 && std::isfinite(tl) ? t / tl : anyOrthogonal(n);
}

// The rotation with columns (t, cross(n, t), n) as a unit quaternion (Shepperd).
Quat quaternionOf(glm::dvec3 t, glm::dvec3 n) {
  const glm::dvec3 b = glm::cross(n, t);
  // m[col][row]
  const double m00 = t.x, m10 = t.y, m20 = t.z;  // column 0
  const double m01 = b.x, m11 = b.y, m21 = b.z;  // column 1
  const double m02 = n.x, m12 = n.y, m22 = n.z;  // column 2
  const double trace = m00 + m11 + m22;
  Quat q;
  if (trace > 0) {
    double s = std::sqrt(trace + 1.0) * 2;
    q = {(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s};
  } else if (m00 > m11 && m00 > m22) {
    double s = std::sqrt(1.0 + m00 - m11 - m22) * 2;
    q = {0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s};
  } else if (m11 > m22) {
    double s = std::sqrt(1.0 + m11 - m00 - m22) * 2;
    q = {(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s};
  } else {
    double s = std::sqrt(1.0 + m22 - m00 - m11) * 2;
    q = {(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s};
  }
  return glm::normalize(q);
}


// The decoder's quaternion (x, y, z, w), unit length; the float arithmetic of shaders/tbn.h.
glm::vec4 decodeQuaternion(uint32_t bits) {
  const uint32_t largest = (bits >> 21) & 3u;
  const float sign = ((bits >> 23) & 1u) != 0 ? -1.0f : 1.0f;
  glm::vec3 c;
  for (uint32_t i = 0; i < 3; ++i) {
    c[int(i)] = (float((bits >> (7 * i)) & 127u) / 63.5f - 1.0f) * 0.70710678f;
  }
  const float l = sign * std::sqrt(std::max(0.0f, 1.0f - glm::dot(c, c)));
  glm::vec4 q;
  uint32_t j = 0;
  for (uint32_t i = 0; i < 4; ++i) q[int(i)] = i == largest ? l : c[int(j++)];
  return glm::normalize(q);
}

}  // namespace

std::string_view toString(TangentFrameEncoding encoding) {
  return encoding == TangentFrameEncoding::Quaternion ? "quaternion" : "float";
}

std::optional<TangentFrameEncoding> parseTangentFrameEncoding(std::string_view name) {
  for (auto e : {TangentFrameEncoding::Float, TangentFrameEncoding::Quaternion}) {
    if (name == toString(e)) return e;
  }
  return std::nullopt;
}

uint32_t encodeTangentFrame(glm::vec3 normal, glm::vec4 tangent) {
  glm::dvec3 n, t;
  orthonormalise(normal, tangent, n, t);
  Quat q = quaternionOf(t, n);
  uint32_t largest = 0;
  for (uint32_t i = 1; i < 4; ++i) {
    if (std::abs(q[int(i)]) > std::abs(q[int(largest)])) largest = i;
  }
  const bool negative = tangent.w < 0.0f;  // bitangent sign -1
  if ((q[int(largest)] < 0) != negative) q = -q;
  // The three others, rounded; then the best of the 8 floor/ceil neighbours
  // (the one whose decoded rotation is closest to q), which can only lower
  // the error below the rounding bound.
  double v[3];
  for (uint32_t i = 0, j = 0; i < 4; ++i) {
    if (i != largest) v[j++] = q[int(i)];
  }
  uint32_t lo[3];
  for (int i = 0; i < 3; ++i) {
    double k = (v[i] * kSqrt2 + 1.0) * 63.5;
    lo[i] = uint32_t(std::clamp(std::floor(k), 0.0, 126.0));
  }
  const uint32_t header = (largest << 21) | (negative ? 1u << 23 : 0u);
  uint32_t best = 0;
  double bestDot = -1;
  for (uint32_t corner = 0; corner < 8; ++corner) {
    uint32_t bits = header;
    for (uint32_t i = 0; i < 3; ++i) bits |= (lo[i] + ((corner >> i) & 1u)) << (7 * i);
    const glm::dvec4 d = glm::dvec4(decodeQuaternion(bits));
    const double dot = std::abs(glm::dot(d, q));
    if (dot > bestDot) {
      bestDot = dot;
      best = bits;
    }
  }
  return best;
}

DecodedFrame decodeTangentFrame(uint32_t bits) {
  const glm::vec4 q = decodeQuaternion(bits);
  const float x = q.x, y = q.y, z = q.z, w = q.w;
  DecodedFrame f;
  f.tangent = glm::vec4(1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y),
                        ((bits >> 23) & 1u) != 0 ? -1.0f : 1.0f);
  f.normal = glm::vec3(2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y));
  return f;
}

double angleDeg(glm::vec3 a, glm::vec3 b) {
  glm::dvec3 da(a), db(b);
  double la = glm::length(da), lb = glm::length(db);
  if (!(la > 0) || !(lb > 0)) return 0;
  // atan2 of |cross| and dot: accurate at small angles, unlike acos.
  return std::atan2(glm::length(glm::cross(da, db)), glm::dot(da, db)) * 180.0 / 3.14159265358979323846;
}

nlohmann::json tangentFrameErrors(const std::vector<glm::vec3>& normals, const std::vector<glm::vec4>& tangents) {
  double nMax = 0, nSum = 0, tMax = 0, tSum = 0, oMax = 0, oSum = 0;
  uint64_t flips = 0;
  const size_t count = std::min(normals.size(), tangents.size());
  for (size_t i = 0; i < count; ++i) {
    glm::dvec3 n, t;
    orthonormalise(normals[i], tangents[i], n, t);
    const DecodedFrame d = decodeTangentFrame(encodeTangentFrame(normals[i], tangents[i]));
    const double ne = angleDeg(glm::vec3(n), d.normal), te = angleDeg(glm::vec3(t), glm::vec3(d.tangent));
    // What orthonormalising moved: the stored tangent's angle to the one encoded.
    const double oe = glm::length(glm::vec3(tangents[i])) > 0 ? angleDeg(glm::vec3(tangents[i]), glm::vec3(t)) : 0;
    nMax = std::max(nMax, ne);
    tMax = std::max(tMax, te);
    oMax = std::max(oMax, oe);
    nSum += ne;
    tSum += te;
    oSum += oe;
    if ((d.tangent.w < 0) != (tangents[i].w < 0)) ++flips;
  }
  const double n = count == 0 ? 1.0 : double(count);
  return {{"normal_error_deg", {{"max", nMax}, {"mean", nSum / n}}},
          {"tangent_error_deg", {{"max", tMax}, {"mean", tSum / n}}},
          {"orthonormalisation_deg", {{"max", oMax}, {"mean", oSum / n}}},
          {"handedness_flips", flips},
          {"bound_deg", kTbnErrorBoundDeg}};
}

Result<PackedVertexBuffer> buildPackedVertices(gpu::Context& ctx, const GpuScene& scene) {
  const gpu::Buffer& source = scene.vertices();
  const std::vector<uint8_t> raw = gpu::readBuffer(ctx, source);
  const size_t count = raw.size() / sizeof(shaders::Vertex);
  std::vector<PackedVertex> packed(count);
  std::vector<glm::vec3> normals(count);
  std::vector<glm::vec4> tangents(count);
  for (size_t i = 0; i < count; ++i) {
    shaders::Vertex v;
    std::memcpy(&v, raw.data() + i * sizeof v, sizeof v);
    normals[i] = {v.normal[0], v.normal[1], v.normal[2]};
    tangents[i] = {v.tangent[0], v.tangent[1], v.tangent[2], v.tangent[3]};
    PackedVertex& p = packed[i];
    std::memcpy(p.position, v.position, sizeof p.position);
    std::memcpy(p.uv, v.uv, sizeof p.uv);
    p.tbn = encodeTangentFrame(normals[i], tangents[i]);
  }
  PackedVertexBuffer out;
  const VkDeviceSize bytes = std::max<VkDeviceSize>(count * sizeof(PackedVertex), 16);
  out.buffer = gpu::createBuffer(ctx, bytes,
                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_VERTEX_BUFFER_BIT |
                                     VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                 gpu::MemoryUse::DeviceLocal);
  if (count > 0) {
    gpu::uploadBuffer(ctx, out.buffer, {reinterpret_cast<const uint8_t*>(packed.data()), count * sizeof(PackedVertex)});
  }
  VkMemoryRequirements r;
  vkGetBufferMemoryRequirements(ctx.device, out.buffer.buffer, &r);
  out.info.name = "vertices";
  out.info.kind = ResourceKind::Buffer;
  out.info.elementBytes = sizeof(PackedVertex);
  out.info.allocationBytes = r.size;
  out.info.usage = "vertex|storage";
  out.info.objects = {gpu::objectOf(out.buffer.buffer)};
  out.stats = tangentFrameErrors(normals, tangents);
  out.stats["encoding"] = "quaternion";
  out.stats["vertex_stride_bytes"] = sizeof(PackedVertex);
  out.stats["tbn_bytes"] = kTbnBits / 8;
  out.stats["tbn_word_bytes"] = sizeof(uint32_t);
  out.stats["float_vertex_stride_bytes"] = sizeof(shaders::Vertex);
  out.stats["vertex_count"] = count;
  return out;
}

}  // namespace tally::renderers
