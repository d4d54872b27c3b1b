// Analytic predictions of every renderer's per-pass, per-resource counts on
// the procedural scenes planes and sky, derived from the scene parameters
// (docs/measurement.md, "Analytic predictions"):
// - which pixels the quads cover, from their projected edges and the
//   rasterizer's rule (pixel centres, 8 sub-pixel bits, top-left);
// - which fragments pass the early depth and stencil tests, from the draw
//   order, the depth pre-pass and the stencil sky mask;
// - what each shader reads and writes per invocation, from its source.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <vulkan/vulkan.h>
#include <nlohmann/json.hpp>

namespace tally::renderers::analytic {

// Rows of a W x H framebuffer whose pixel centres lie inside a quad edge
// pair at framebuffer y `top` (inside below) and `bottom` (inside above),
// both spanning the full width. Edges are snapped to 1/256 pixel; a centre on
// the top edge is inside, one on the bottom edge outside (top-left rule).
struct Rows {
  uint32_t first = 0;
  uint32_t count = 0;
  bool ambiguous = false;  // an edge lies so near a snapping midpoint that float rounding could move it
};
Rows coveredRows(double top, double bottom, uint32_t height);

// What the rasterizer sees of an analytic scene (planes or sky spec).
struct Geometry {
  uint32_t layers = 1;       // quads, one draw of 2 triangles each, all covering the same pixels
  bool backToFront = false;  // the draw order: every layer passes the depth test
  Rows rows;                 // rows every quad covers (all columns: the quads span the full width)
  uint64_t covered = 0;      // pixels one quad covers (P)
  uint64_t pixels = 0;       // W x H
};
Geometry geometryOf(const nlohmann::json& spec, VkExtent2D extent);

// count = perFragment x counted fragment invocations of the pass
//       + perVertex x vertex invocations of the pass + constant.
struct Term {
  std::string resource;  // a resource name, or a prefix ending in '.' (every map kind)
  bool write = false;
  std::string source = "counter";  // or "derived"
  uint64_t perFragment = 0;
  uint64_t perVertex = 0;
  uint64_t constant = 0;
  uint32_t elementBytes = 0;  // checked when not 0: bytes = count x elementBytes
  uint64_t count(uint64_t fragments, uint64_t vertices) const {
    return perFragment * fragments + perVertex * vertices + constant;
  }
};

struct PassPrediction {
  std::string name;
  uint64_t fragments = 0;   // counted fragment invocations (after the early tests)
  uint64_t rasterized = 0;  // fragments the rasterizer generates, before the early tests
  // Vertex invocations: between `minVertices` and `maxVertices` (an indexed
  // quad runs its vertex shader 4 to 6 times, as the device reuses vertices),
  // measured from the vertex attribute reads (`vertexAttributes` per vertex).
  uint32_t vertexAttributes = 0;
  uint64_t minVertices = 0, maxVertices = 0;
  std::vector<Term> terms;
};

struct DeviceTraits {
  bool barycentricExtension = false;  // visbuffer notes.barycentrics == "extension"
  uint32_t lights = 0;                // RendererOptions::lights
};

// Every pass of `renderer`, in order, with every access it makes, for the
// variant `options` (canonical, options.hpp): forward's "output" and
// "zprepass", deferred's "zprepass".
std::vector<PassPrediction> predict(const std::string& renderer, const Geometry& g, const DeviceTraits& device,
                                    const nlohmann::json& options = nlohmann::json::object());

// Forward output=overdraw|overshading: how many pixels receive each count of
// forward-pass fragments (count -> pixels, every count that occurs, 0 for the
// pixels no quad covers). Every quad covers the same pixels, so a covered
// pixel receives every layer without a depth test (overdraw), every layer
// back to front or only the nearest front to back with it, and only the
// nearest after a depth pre-pass.
std::map<uint64_t, uint64_t> countHistogram(const Geometry& g, const std::string& output, bool prepass);

}  // namespace tally::renderers::analytic
