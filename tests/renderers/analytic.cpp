#include "analytic.hpp"

#include <algorithm>
#include <cmath>

namespace tally::renderers::analytic {
namespace {

// Sub-pixel precision of the rasterizer: lavapipe snaps vertices to 1/256
// pixel (FIXED_ORDER 8), as NVIDIA does (subPixelPrecisionBits = 8).
constexpr double kSubpixelSteps = 256.0;
// Float rounding in the vertex pipeline moves an edge by ~1e-5 pixel
// (relative error ~6e-8 of a ~100-pixel coordinate), well below this margin
// in sub-pixel steps around a snapping midpoint.
constexpr double kAmbiguousSteps = 0.02;

struct SnappedEdge {
  double y = 0;
  bool ambiguous = false;
};

SnappedEdge snap(double y) {
  const double steps = y * kSubpixelSteps;
  const double fraction = steps - std::floor(steps);
  return {std::round(steps) / kSubpixelSteps, std::abs(fraction - 0.5) < kAmbiguousSteps};
}

// The first row whose centre (r + 0.5) is at or below the edge y.
int64_t firstRowAtOrBelow(double y, uint32_t height) {
  return std::clamp<int64_t>(int64_t(std::ceil(y - 0.5)), 0, height);
}

constexpr uint32_t kTrianglesPerQuad = 2;
constexpr uint32_t kQuadUniqueVertices = 4;
constexpr uint32_t kQuadIndices = kTrianglesPerQuad * 3;
constexpr uint32_t kFullScreenVertices = 3;  // the full-screen passes draw one triangle
constexpr uint32_t kMapsPerMaterial = 5;     // shared.h kMapCount

// Bytes per event of the formats the renderers create (docs/renderers.md).
constexpr uint32_t kHdrBytes = 8;          // R16G16B16A16_SFLOAT
constexpr uint32_t kFinalBytes = 4;        // R8G8B8A8_SRGB
constexpr uint32_t kDepthStencilBytes = 5;  // D32_SFLOAT_S8_UINT, written by a depth-writing pass
constexpr uint32_t kDepthAspectBytes = 4;   // its depth aspect, sampled
constexpr uint32_t kIndexBytes = 4;         // 32-bit indices
constexpr uint32_t kLightBytes = 32;        // PointLight, loaded whole
constexpr uint32_t kCountBytes = 4;         // R32_SFLOAT, forward's overdraw.count
constexpr uint32_t kStencilBytes = 1;       // the S8 aspect, set without depth (forward output=overdraw)

Term read(std::string resource, uint64_t perFragment, uint32_t elementBytes = 0) {
  return {std::move(resource), false, "counter", perFragment, 0, 0, elementBytes};
}
Term write(std::string resource, uint64_t perFragment, uint32_t elementBytes) {
  return {std::move(resource), true, "counter", perFragment, 0, 0, elementBytes};
}

// Blinn-Phong in common.h shade(): camera.position, lighting.ambient and
// lighting.lightCount once, lights[i] whole for every light (read before the
// falloff test, so always).
std::vector<Term> shadeTerms(const DeviceTraits& device, uint64_t cameraReads) {
  return {read("camera", cameraReads), read("lighting", 2), read("lights", device.lights, kLightBytes)};
}

// A geometry pass over the layers: mesh.vert-style vertex stage reading
// `attributes` vertex inputs, draws[drawIndex].model and camera.viewProj
// once per vertex; index fetches derived from the indices drawn.
PassPrediction meshPass(std::string name, const Geometry& g, uint64_t fragments, uint32_t attributes) {
  PassPrediction p;
  p.name = std::move(name);
  p.fragments = fragments;
  p.rasterized = uint64_t(g.layers) * g.covered;  // every layer's fragments reach the early tests
  p.vertexAttributes = attributes;
  p.minVertices = uint64_t(g.layers) * kQuadUniqueVertices;
  p.maxVertices = uint64_t(g.layers) * kQuadIndices;
  p.terms = {{"vertices", false, "counter", 0, attributes, 0, 0},
             {"draws", false, "counter", 0, 1, 0, 0},
             {"camera", false, "counter", 0, 1, 0, 0},
             {"indices", false, "derived", 0, 0, uint64_t(g.layers) * kQuadIndices, kIndexBytes}};
  return p;
}

void add(PassPrediction& p, std::vector<Term> terms) {
  for (auto& t : terms) {
    auto same = std::find_if(p.terms.begin(), p.terms.end(), [&](const Term& u) {
      return u.resource == t.resource && u.write == t.write && u.source == t.source;
    });
    if (same == p.terms.end()) {
      p.terms.push_back(std::move(t));
    } else {  // the vertex and the fragment stage read the same resource
      same->perFragment += t.perFragment;
      same->perVertex += t.perVertex;
      same->constant += t.constant;
    }
  }
}

// A full-screen pass: one triangle over every pixel; `fragments` of them
// pass the stencil test.
PassPrediction fullScreenPass(std::string name, const Geometry& g, uint64_t fragments) {
  PassPrediction p;
  p.name = std::move(name);
  p.fragments = fragments;
  p.rasterized = g.pixels;
  return p;
}

// forward.frag / gbuffer.frag: the five maps of the draw's material and
// materials[].baseColor, materials[].roughnessFactor per fragment.
std::vector<Term> materialTerms() { return {read("material_maps.", kMapsPerMaterial), read("materials", 2)}; }

Term depthWrite() { return {"depth", true, "derived", 1, 0, 0, kDepthStencilBytes}; }

std::vector<PassPrediction> ownPasses(const std::string& renderer, const Geometry& g, const DeviceTraits& d,
                                      const nlohmann::json& options) {
  // Early depth test, LESS: back to front every layer is nearer than the
  // last and is shaded; front to back only the first (nearest) one.
  const uint64_t shaded = (g.backToFront ? g.layers : 1) * g.covered;
  if (renderer == "forward" || renderer == "forward-zprepass") {
    std::vector<PassPrediction> out;
    const bool prepass = renderer == "forward-zprepass" || options.value("zprepass", false);
    const std::string output = options.value("output", "shaded");
    const bool counting = output != "shaded", overdraw = output == "overdraw";
    if (prepass) {
      // zprepass.vert: the position only; the counting-only fragment shader reads nothing.
      PassPrediction z = meshPass("zprepass", g, shaded, 1);
      add(z, {depthWrite()});
      out.push_back(z);
    }
    // After the pre-pass, depth EQUAL passes only the nearest layer's
    // fragments; without the depth test (overdraw) every rasterized one.
    const uint64_t fragments = overdraw ? uint64_t(g.layers) * g.covered : prepass ? g.covered : shaded;
    PassPrediction f = meshPass("forward", g, fragments, 4);
    add(f, materialTerms());
    add(f, shadeTerms(d, 1));
    add(f, {write("hdr", 1, kHdrBytes)});
    if (counting) {
      // The count output, and blending's destination reads of both outputs.
      add(f, {write("overdraw.count", 1, kCountBytes), {"hdr", false, "derived", 1, 0, 0, kHdrBytes},
              {"overdraw.count", false, "derived", 1, 0, 0, kCountBytes}});
    }
    if (!prepass) add(f, {overdraw ? Term{"depth", true, "derived", 1, 0, 0, kStencilBytes} : depthWrite()});
    out.push_back(f);
    if (counting) {
      // overdraw_view.frag: one count texel to hdr, every pixel.
      PassPrediction v = fullScreenPass("overdraw_view", g, g.pixels);
      add(v, {read("overdraw.count", 1, kCountBytes), write("hdr", 1, kHdrBytes)});
      out.push_back(v);
    }
    return out;
  }
  if (renderer == "deferred") {
    std::vector<PassPrediction> out;
    const bool prepass = options.value("zprepass", false);
    if (prepass) {  // as forward-zprepass's
      PassPrediction z = meshPass("zprepass", g, shaded, 1);
      add(z, {depthWrite()});
      out.push_back(z);
    }
    PassPrediction gb = meshPass("gbuffer", g, prepass ? g.covered : shaded, 4);
    add(gb, materialTerms());
    add(gb, {write("gbuffer.normal", 1, 8), write("gbuffer.diffuse", 1, 4), write("gbuffer.specular", 1, 4)});
    if (!prepass) add(gb, {depthWrite()});
    out.push_back(gb);
    // lighting.frag: the G-buffer texels; camera.invViewProj and
    // camera.viewport (worldFromDepth) plus shade()'s camera.position.
    PassPrediction l = fullScreenPass("lighting", g, g.covered);
    add(l, {read("depth", 1, kDepthAspectBytes), read("gbuffer.normal", 1, 8), read("gbuffer.diffuse", 1, 4),
            read("gbuffer.specular", 1, 4)});
    add(l, shadeTerms(d, 3));
    add(l, {write("hdr", 1, kHdrBytes)});
    out.push_back(l);
    return out;
  }
  if (renderer != "visbuffer" && renderer != "visbuffer-lean") return {};  // unknown: nothing predicted
  const bool fat = renderer == "visbuffer";
  // Visibility pass. Fat: visibility.vert reads position and uv; without the
  // barycentric extension visibility.frag re-projects the triangle per
  // fragment: 3 indices, 3 vertex positions, draws[].firstIndex,
  // .vertexOffset, .model, camera.viewProj, .viewport (x3 uses, 3 loads).
  // Lean: zprepass.vert (position), and the fragment shader only writes the id.
  PassPrediction v = meshPass("visibility", g, shaded, fat ? 2 : 1);
  if (fat) {
    const bool computed = !d.barycentricExtension;
    add(v, {read("vertices", computed ? 3 : 0), read("draws", computed ? 3 : 0),
            read("camera", computed ? 4 : 0), read("indices", computed ? 3 : 0)});
    add(v, {write("visibility.id", 1, 8), write("visibility.uv_derivatives", 1, 8)});
  } else {
    add(v, {write("visibility.id", 1, 4)});
  }
  add(v, {depthWrite()});
  // Shading pass (stencil == 1): the visibility texel(s), fetchTriangle's 3
  // indices, 3 whole vertices, draws[] firstIndex, vertexOffset, model,
  // materialIndex, materials[] maps, baseColor, roughnessFactor, the five
  // maps. The lean pass also re-projects the triangle: camera.viewProj and
  // camera.viewport (3 loads) besides shade()'s camera.position.
  PassPrediction s = fullScreenPass("shading", g, g.covered);
  add(s, {read("visibility.id", 1, fat ? 8 : 4)});
  if (fat) add(s, {read("visibility.uv_derivatives", 1, 8)});
  add(s, {read("indices", 3, kIndexBytes), read("vertices", 3), read("draws", 4), read("materials", 3),
          read("material_maps.", kMapsPerMaterial)});
  add(s, shadeTerms(d, fat ? 1 : 5));
  add(s, {write("hdr", 1, kHdrBytes)});
  return {v, s};
}

}  // namespace

Rows coveredRows(double top, double bottom, uint32_t height) {
  const SnappedEdge t = snap(top), b = snap(bottom);
  Rows r;
  const int64_t first = firstRowAtOrBelow(t.y, height);  // on the top edge: inside
  const int64_t end = firstRowAtOrBelow(b.y, height);    // on the bottom edge: outside
  r.first = uint32_t(first);
  r.count = uint32_t(std::max<int64_t>(end - first, 0));
  r.ambiguous = t.ambiguous || b.ambiguous;
  return r;
}

Geometry geometryOf(const nlohmann::json& spec, VkExtent2D extent) {
  // server/scenes/procedural.cpp: every quad spans the full width and, in
  // NDC y (down after the projection's flip), [-c, c] for planes and
  // [1 - 2c, 1.5] for sky, with the coverage as a float. Framebuffer y = (ndc + 1) H / 2.
  Geometry g;
  const double h = extent.height;
  const std::string name = spec.value("name", "");
  if (name == "planes") {
    g.layers = spec.value("layers", 8u);
    g.backToFront = spec.value("order", "back-to-front") == "back-to-front";
    const double c = float(spec.value("coverage", 1.0));
    g.rows = coveredRows((1.0 - c) * h / 2, (1.0 + c) * h / 2, extent.height);
  } else {
    const double yHi = float(-1.0 + 2.0 * spec.value("coverage", 0.5));  // the quad's upper edge, world y / s
    g.rows = coveredRows((1.0 - yHi) * h / 2, (1.0 + 1.5) * h / 2, extent.height);
  }
  g.pixels = uint64_t(extent.width) * extent.height;
  g.covered = uint64_t(g.rows.count) * extent.width;
  return g;
}

std::map<uint64_t, uint64_t> countHistogram(const Geometry& g, const std::string& output, bool prepass) {
  uint64_t perCovered = 1;  // the nearest layer only
  if (output == "overdraw" || (!prepass && g.backToFront)) perCovered = g.layers;
  std::map<uint64_t, uint64_t> out;
  if (g.pixels > g.covered) out[0] = g.pixels - g.covered;
  if (g.covered > 0) out[perCovered] += g.covered;
  return out;
}

std::vector<PassPrediction> predict(const std::string& renderer, const Geometry& g, const DeviceTraits& device,
                                    const nlohmann::json& options) {
  std::vector<PassPrediction> passes = ownPasses(renderer, g, device, options);
  // tonemap.frag: hdr and lighting.exposure per pixel, every pixel.
  PassPrediction t = fullScreenPass("tonemap", g, g.pixels);
  add(t, {read("hdr", 1, kHdrBytes), read("lighting", 1), write("final", 1, kFinalBytes)});
  passes.push_back(t);
  // skybox: stencil == 0, the pixels no quad covers; skybox.vert reads
  // camera.invViewProj at each of the triangle's 3 vertices, skybox.frag
  // camera.position and the sky cube per fragment.
  PassPrediction s = fullScreenPass("skybox", g, g.pixels - g.covered);
  add(s, {{"camera", false, "counter", 1, 0, kFullScreenVertices, 0}, read("sky", 1),
          write("final", 1, kFinalBytes)});
  passes.push_back(s);
  return passes;
}

}  // namespace tally::renderers::analytic
