// Compute workloads (docs/techniques.md, "Volume fog", "Ray tracer"): two
// Renderers whose one pass is a compute shader writing every pixel of "hdr"
// with imageStore; the base's tonemap then fills "final". They use the scene
// only for its bounds and the spec's cameras, and are listed apart from the
// renderers (renderer.hpp: workloadNames(), capture specs' "workloads").
//
// volume-fog: rays march `fogSteps` samples through the scene's bounding box,
// filled with a tiled 64^3 R8_UNORM density texture ("fog_density", REPEAT)
// summed over octaves at doubling frequency, composited front to back and
// stopped once the opacity reaches kFogTerminationOpacity. The octave count
// per sample is FogOctaves' choice.
//
// raytrace: `spheres` procedural spheres (a storage buffer "spheres", one
// vec4 per sphere) on a ground plane, one point light; per pixel a primary
// ray and per hit a shadow ray and (up to `bounces`) a reflection ray; every
// ray tests every sphere.
//
// The helpers below are the shaders' math on the CPU: the tests derive the
// counts from them.
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "renderers/options.hpp"
#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"

namespace tally::renderers {

constexpr uint32_t kFogTextureSize = 64;          // texels per side of "fog_density"
constexpr float kFogTerminationOpacity = 0.99f;  // early termination: 1 - transmittance >= this
constexpr uint32_t kFogMaxOctavesLimit = 8;

std::string_view toString(FogOctaves mode);  // "fixed", "dynamic", "constant"
std::optional<FogOctaves> parseFogOctaves(std::string_view name);

// The workloads' rows of the option table (options.cpp calls it).
void addWorkloadOptions(std::vector<OptionDef>& defs);

// The density texture: kFogTextureSize^3 bytes, x fastest, then y, then z;
// deterministic, periodic (it tiles under REPEAT).
std::vector<uint8_t> fogDensityTexels();

// The fog box and its constants, from the scene bounds.
struct FogVolume {
  glm::vec3 min{0.0f}, max{0.0f};
  float tileSize = 1.0f;  // world size of one repetition of the texture (octave 0)
  float t0 = 1.0f;        // dynamic octaves: the distance up to which every octave is read
  float sigmaScale = 0.0f;  // extinction per metre at density 1 (options' fogDensity / diagonal x 4)
};
FogVolume fogVolumeFor(const scenes::Bounds& bounds, float densityOption);

// Octaves read at distance t in dynamic mode: clamp(max - floor(log2(t / t0)), 1, max).
uint32_t fogDynamicOctaves(float t, float t0, uint32_t maxOctaves);

// The primary ray through pixel (x, y)'s centre, as the compute shaders make
// it from the camera uniform: view-space (ndc.x / proj[0][0], ndc.y /
// proj[1][1], -1), normalised, rotated to world. Returns the direction.
glm::vec3 workloadRayDirection(const glm::mat4& view, const glm::mat4& proj, glm::vec2 viewport, uint32_t x,
                               uint32_t y);

// The ray tracer's scene: spheres (xyz centre, w radius) resting on the ground
// plane y = bounds.min.y inside the bounds, and the light above the centre.
std::vector<glm::vec4> raytraceSpheres(const scenes::Bounds& bounds, uint32_t count);
glm::vec3 raytraceLight(const scenes::Bounds& bounds);
float raytraceEpsilon(const scenes::Bounds& bounds);  // ray offsets and minimum hit distance

}  // namespace tally::renderers
