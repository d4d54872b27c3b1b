// Forward output=density (docs/techniques.md, "Mesh density"): the CPU side.
// A pass over the scene's triangles projected with a sample's camera
// classifies each one in screen space exactly as shaders/density.h does, and
// a CPU rasterisation (pixel centres, no depth test) estimates the quads
// each triangle touches, the fallback for devices without quad operations in
// fragment shaders.
#pragma once

#include <cstdint>
#include <map>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <vulkan/vulkan.h>

#include "renderers/gpu_scene.hpp"

namespace tally::renderers::density {

enum class TriangleClass : uint32_t { Normal = 0, SubPixel = 1, LongThin = 2 };  // density.h kDensity*

constexpr double kSubPixelArea = 1.0;  // px^2: below it a triangle is sub-pixel
constexpr double kThinAltitude = 1.0;  // px: a smallest altitude below it (area >= 1) is long-thin
constexpr int kLowestBucket = -10;     // log2 area buckets: [2^k, 2^(k+1)); this one takes all smaller (and 0)
constexpr int kHighestBucket = 24;     // and this one all larger

// From the three vertices in pixels (x right, y down).
TriangleClass classify(const glm::dvec2& p0, const glm::dvec2& p1, const glm::dvec2& p2);
double screenArea(const glm::dvec2& p0, const glm::dvec2& p1, const glm::dvec2& p2);

struct Census {
  uint64_t submitted = 0;    // triangles drawn
  uint64_t inView = 0;       // not entirely outside one clip plane, not of zero area (no culling: both faces drawn)
  uint64_t frontFacing = 0;  // of those, wound counter-clockwise on screen (the scene's front faces)
  uint64_t clippedNear = 0;  // of those, with a vertex in front of the near plane: class normal, no area
  uint64_t subPixel = 0, longThin = 0, normal = 0;  // the in-view triangles by class
  std::map<int, uint64_t> log2Area;  // bucket k (area in [2^k, 2^(k+1)) px^2) -> in-view triangles, not near-clipped
  // CPU rasterisation (pixel centres inside all three edges; no depth test):
  uint64_t rasterSamples = 0;  // pixel centres covered, summed over triangles (fragments without depth test)
  uint64_t rasterQuads = 0;    // 2x2 quads with a covered centre, summed over triangles
  uint64_t rasterPixels = 0;   // distinct pixels covered by any triangle
};

// Every draw's triangles through `viewProj` (models are the identity) on an `extent` framebuffer.
Census census(const GpuScene& scene, const glm::mat4& viewProj, VkExtent2D extent);

// The {"density": ...} extras: the census, the count and lane targets'
// texels (R32_SFLOAT each, empty lanes when the GPU did not count them) and
// the final image (RGBA8, per-class pixels by the view's hues).
nlohmann::json extras(const Census& census, const std::vector<uint8_t>& countTexels,
                      const std::vector<uint8_t>& laneTexels, bool gpuLanes, const std::vector<uint8_t>& image,
                      uint64_t countedFragments, bool instrumented);

}  // namespace tally::renderers::density
