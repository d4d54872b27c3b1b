// Packed tangent frames (docs/techniques.md, "Packed tangent frames"): the
// vertex's normal, tangent and bitangent sign as one unit quaternion in 24
// bits ("smallest three"), and the packed vertex buffer the tangent_frame =
// quaternion variant draws from. The GLSL decoder is shaders/tbn.h.
//
// Bit layout of the 24 bits (low bits of a 32-bit word; bits 24..31 are 0):
//   bits  0..6   the first of the three smaller components  } in x, y, z, w order,
//   bits  7..13  the second                                 } the largest skipped;
//   bits 14..20  the third                                  } k in 0..127: v = (k / 63.5 - 1) / sqrt 2
//   bits 21..22  index of the largest-magnitude component (0 x, 1 y, 2 z, 3 w)
//   bit  23      the sign of that component, which is the handedness: q and -q
//                are the same rotation, so the encoder picks the sign of q whose
//                largest component is >= 0 for bitangent sign +1 and < 0 for -1;
//                the decoder rebuilds it as +-sqrt(1 - a^2 - b^2 - c^2).
// The frame is the rotation whose columns are (tangent, cross(normal, tangent),
// normal); bitangent = cross(normal, tangent) * sign, as in glTF and the shaders.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "gpu/context.hpp"
#include "gpu/resources.hpp"
#include "renderers/renderer.hpp"

namespace tally::renderers {

class GpuScene;

std::string_view toString(TangentFrameEncoding encoding);  // "float", "quaternion"
std::optional<TangentFrameEncoding> parseTangentFrameEncoding(std::string_view name);

constexpr uint32_t kTbnBits = 24;
constexpr uint32_t kTbnComponentBits = 7;
// Quantisation half-step of a smaller component, over [-1/sqrt 2, 1/sqrt 2]
// in 127 steps: 1 / (127 sqrt 2).
constexpr double kTbnHalfStep = 0.0055677699306027366;
// The worst-case angle (degrees) between a frame vector and its decoded
// version, derived in docs/techniques.md: a component error e (|e_i| <= half
// step) moves q on the unit 3-sphere by at most |e| sqrt(1 + (sum |a_i| /
// largest)^2 / 3) <= sqrt 12 x half step (all four components 1/2), and a
// rotation error of angle phi = 2 x that moves any vector by at most phi:
// 4 sqrt 3 / (127 sqrt 2) rad = 2.2102 degrees, to first order.
constexpr double kTbnFirstOrderBoundDeg = 2.2101641609773499;
// The bound the tests assert: the first-order one plus 1% for the second-order
// terms (the step is 0.8% of the smallest largest component, 1/2).
constexpr double kTbnErrorBoundDeg = kTbnFirstOrderBoundDeg * 1.01;

// The vertex of the quaternion variant: 24 bytes (std430 and vertex input
// alike), the 3 bytes of frame in a 32-bit word, since the float attributes
// need 4-byte alignment (a 23-byte stride would misalign every other
// position) and a 3-byte R8G8B8 attribute is an optional vertex format.
struct PackedVertex {
  float position[3];
  float uv[2];
  uint32_t tbn;  // the 24 bits above; fetched as R32_UINT / uint
};
static_assert(sizeof(PackedVertex) == 24);

// Orthonormalises (n, t) first (Gram-Schmidt of t against n; a degenerate t
// becomes any vector orthogonal to n); w < 0 is bitangent sign -1.
uint32_t encodeTangentFrame(glm::vec3 normal, glm::vec4 tangent);
// The C++ twin of shaders/tbn.h's decodeTangentFrame: unit normal, unit
// tangent and the sign (+-1) in tangent.w.
struct DecodedFrame {
  glm::vec3 normal;
  glm::vec4 tangent;
};
DecodedFrame decodeTangentFrame(uint32_t bits);

// Angle between two vectors in degrees (0 for a zero vector).
double angleDeg(glm::vec3 a, glm::vec3 b);

struct PackedVertexBuffer {
  gpu::Buffer buffer;  // vertex | storage, PackedVertex[vertex count]
  ResourceInfo info;   // "vertices": elementBytes 24, the real allocation
  // {"encoding", "vertex_stride_bytes", "tbn_bytes", "tbn_word_bytes",
  //  "vertex_count", "normal_error_deg": {max, mean}, "tangent_error_deg",
  //  "orthonormalisation_deg", "handedness_flips", "bound_deg"}
  nlohmann::json stats;
};

// Reads the scene's float vertices back, packs them and uploads the packed
// buffer; the errors are every vertex's decoded frame against its
// orthonormalised float frame.
Result<PackedVertexBuffer> buildPackedVertices(gpu::Context& ctx, const GpuScene& scene);

// Errors of the packed frames of `vertices` (shaders::Vertex layout floats).
nlohmann::json tangentFrameErrors(const std::vector<glm::vec3>& normals, const std::vector<glm::vec4>& tangents);

}  // namespace tally::renderers
