// Sweep "visbuffer-precision": what the fat visibility buffer's packing costs.
// It stores barycentrics with packUnorm2x16 (steps of 1/65535) and uv
// derivatives with packHalf2x16 (11 significant bits); the founding study
// stored the derivatives with packUnorm2x16, which clamps every component to
// [0, 1], so negative derivatives become 0. Each point renders one textured
// plane at a distance, tessellated into right triangles of a leg length,
// with float32 barycentrics and derivatives (the reference) and with each
// packing (RendererOptions::visibility), reads back what the visibility pass
// wrote (Renderer::targetBytes) and measures, against the reference: the
// final image, the mip level the stored derivatives select, and the uv the
// stored barycentrics interpolate. Beside each measured figure, the analytic
// one (docs/measurement.md, "Sweep: barycentric and derivative precision").
//
// The plane is z = -d + a x + b y in view space (= world: the camera sits at
// the origin looking down -Z), tilted as the depth sweep's so the distance
// varies over the image; uv = (texels_per_metre / texture_size) R(rotation)
// (x, -y): at rotation 0, u runs right and v down the screen, so every
// derivative component is >= 0 up to the tilt's perspective terms.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "sweeps/options.hpp"
#include "common/resolution.hpp"
#include "common/result.hpp"
#include "gpu/context.hpp"
#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"

namespace tally::sweeps {

inline constexpr std::string_view kPrecisionSweepName = "visbuffer-precision";
inline constexpr size_t kMaxPrecisionAxis = 64;      // values per axis (distances, triangle sizes)
inline constexpr size_t kMaxPrecisionRenders = 512;  // distances x sizes x (reference + variants)
inline constexpr uint64_t kMaxPrecisionTriangles = uint64_t{1} << 20;  // per point: the grid of one plane
inline constexpr uint32_t kMinPrecisionTexture = 16,
                          kMaxPrecisionTexture = 8192;  // texture_size, powers of two
// The plane's view depth runs from d / (1 + kPrecisionTilt) to d / (1 - kPrecisionTilt) corner to corner.
inline constexpr double kPrecisionTilt = 0.1;

struct PrecisionSweepSpec {
  std::vector<double> distances;      // metres from the eye to the plane at the screen centre
  std::vector<double> triangleSizes;  // metres: the grid's right triangles' leg length
  uint32_t textureSize = 1024;        // texels per side, a power of two
  double texelsPerMetre = 256;        // uv scale: uv = position x texels_per_metre / texture_size
  double uvRotationDeg = 30;          // uv rotated against the screen axes
  Resolution resolution = {96, 64};
  double fovDeg = 60.0;       // vertical
  double imageThreshold = 8;  // max abs difference, 8-bit levels
  double mipThreshold = 0.5;  // max abs mip-level difference, levels
  nlohmann::json source;

  uint32_t levels() const;  // of the texture's mip chain: log2(texture_size) + 1
};

Result<PrecisionSweepSpec> parsePrecisionSweepSpec(const nlohmann::json& spec);

// One rendering of each point; every variant is compared with the reference.
struct PrecisionVariant {
  std::string name;
  renderers::VisibilityEncoding encoding;
};
// float32 barycentrics and derivatives.
PrecisionVariant precisionReference();
// "reference" (a second reference render: the control, exactly zero error),
// "unorm16-barycentrics" (unorm16, float32), "half-derivatives" (float32,
// half), "study-derivatives" (float32, unorm16-clamped), "tally" (unorm16,
// half: the renderer's default), "study" (unorm16, unorm16-clamped).
std::vector<PrecisionVariant> precisionVariants();

// The diffuse map: texture_size square, sRGB, with its own mip chain: level L
// is one colour of a 7-colour cycle (neighbouring levels differ), times a
// texel checker (1 or 0.35) and +-10% of hash per texel, so a wrong uv and a
// wrong mip level both change the image.
scenes::Texture precisionTexture(uint32_t size);

// The scene of one point: the tilted plane at `distance`, covering the view
// with a margin, as a grid of right triangles with legs `triangleSize` along
// x and y; one material with precisionTexture in the diffuse slot. Fails,
// naming `field`, when the grid needs more than kMaxPrecisionTriangles.
Result<scenes::Scene> precisionScene(const PrecisionSweepSpec& spec, double distance, double triangleSize,
                                     const std::string& field = "triangle_sizes");
// At the origin looking down -Z with the spec's field of view.
scenes::Camera precisionCamera(const PrecisionSweepSpec& spec);

// The isotropic level of detail (the Vulkan spec's, with vector lengths):
// log2(max(|dx|, |dy|) x textureSize), clamped to [0, levels - 1] as the
// sampler clamps it; 0 where both derivatives are 0 (log2 0 = -inf).
double mipLevelOf(glm::dvec2 dx, glm::dvec2 dy, uint32_t textureSize, uint32_t levels);

// packUnorm2x16 rounds b x 65535 (computed in float, so within 65535 x 2^-24
// of a step) to the nearest step: each stored barycentric is within
// 0.5 / 65535 + 2^-24 of the float it came from.
double unorm16BarycentricBound();
// The uv error in texels that bound allows in a triangle with uv edges
// e1 = uv1 - uv0, e2 = uv2 - uv0: bound x (|e1| + |e2|) x textureSize.
double barycentricUvBound(glm::dvec2 e1, glm::dvec2 e2, uint32_t textureSize);
// packHalf2x16 keeps 11 significant bits: each component within a factor
// 1 +- 2^-11 of itself (round to nearest), so is a vector's length, and the
// level of detail moves by at most -log2(1 - 2^-11) ~ 7.05e-4 levels. Below
// 2^-14 halves are subnormal with a fixed step of 2^-24, so a component's
// error is at most 2^-11 max(|c|, 2^-14); where the level is above 0 the
// length is at least 1 / texture_size, which widens the factor by at most
// sqrt(1 + (texture_size 2^-14)^2): 1.002 at 1024 texels, 1.118 at 8192.
double halfMipLevelBound(uint32_t textureSize);

Result<nlohmann::json> runPrecisionSweep(gpu::Context& ctx, const PrecisionSweepSpec& spec,
                                         const SweepOptions& options);

}  // namespace tally::sweeps
