// Sweep "material-edges": what picking a pixel's material maps without the
// nonuniformEXT qualifier does at material boundaries, against the material
// cell size on screen. Each point renders a plane facing the camera, split
// into a checkerboard of square cells of `cell_size` pixels (neighbours always
// differ; one draw per material, every cell of it in one mesh) with flat,
// strongly distinct diffuse maps, once with the correct per-pixel selection
// ("nonuniform", the reference) and once per compared selection ("uniform":
// the founding study's index without nonuniformEXT; "first-lane": every lane
// takes the first active lane's maps, a model of a scalarising driver). A
// pixel is wrong where its colour differs from the reference. The boundary
// masks come from the cell layout on the CPU, not from the images: pixels
// whose 2x2 quad, or whose aligned subgroup-sized block, holds more than one
// material (docs/measurement.md, "Sweep: material edges").
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "sweeps/options.hpp"
#include "common/resolution.hpp"
#include "common/result.hpp"
#include "gpu/context.hpp"
#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"

namespace tally::sweeps {

inline constexpr std::string_view kEdgesSweepName = "material-edges";
inline constexpr uint32_t kMaxEdgeMaterials = 16;
inline constexpr uint32_t kMaxEdgeCellSize = 4096;  // pixels; beyond it one cell covers any sane view
// Cells drawn per point (the view plus a margin of one cell): 4 vertices of
// 48 bytes each, so 2^18 cells upload 48 MiB of vertices.
inline constexpr uint64_t kMaxEdgeCells = 1u << 18;
// Wrong pixels are counted by their Chebyshev distance to the nearest pixel of
// another material, 1..kEdgeDistanceBins, and one bin beyond (or none in view).
inline constexpr uint32_t kEdgeDistanceBins = 8;

struct EdgesSweepSpec {
  std::string renderer = "visbuffer";
  // Compared against "nonuniform", in spec order; empty: those of "first-lane"
  // and "uniform" the device supports. "nonuniform" itself is a control: it
  // must match the reference exactly.
  std::vector<renderers::MaterialSelection> selections;
  std::vector<uint32_t> cellSizes;  // pixels per cell side, in spec order
  uint32_t materials = 4;
  Resolution resolution = {96, 64};
  bool sameTexture = false;  // every material's diffuse map has the same texels (a control)
  double threshold = 0.01;   // wrong pixels / covered pixels
  nlohmann::json source;
};

// Renderers whose shading pass selects the material per pixel.
std::vector<std::string> edgeRenderers();  // "visbuffer", "visbuffer-lean"

Result<EdgesSweepSpec> parseEdgesSweepSpec(const nlohmann::json& spec,
                                           const std::vector<std::string>& knownRenderers);

// The scene's layout in pixels: cell (i, j) spans x in [i s, (i + 1) s) and y
// in [j s, (j + 1) s) from the top-left corner of the image, so with an even
// s no 2x2 quad (aligned to even pixels) straddles a cell edge. Its material
// is (i + k j) mod n with k = 1 for two materials (a checkerboard) and 2 for
// more (then diagonal neighbours differ too).
uint32_t edgeMaterialAt(int64_t x, int64_t y, uint32_t cellSize, uint32_t materials);

// The plane of one point: cells as edgeMaterialAt lays them out (plus one
// cell of margin), one mesh per material with a flat diffuse map of its own
// hue (material 0's for every one with spec.sameTexture). For the view of a
// camera at the origin looking down -Z (edgeCamera()).
scenes::Scene edgeScene(const EdgesSweepSpec& spec, uint32_t cellSize);
scenes::Camera edgeCamera();

// Of the pixels of an infinite plane laid out as above, the fraction whose
// aligned `block` x `block` square holds more than one material: per axis,
// the share of blocks that a cell edge crosses (counted over one period,
// lcm(cellSize, block)), f; in 2D 1 - (1 - f)^2.
double edgeBlockFraction(uint32_t cellSize, uint32_t block);

// The side of the aligned square block assumed to hold any subgroup of
// `subgroupSize` fragment lanes: the smallest power of two n >= 2 with
// n * n >= subgroupSize (lavapipe's 8 lanes: 4, which holds 4x2 and 2x4).
uint32_t subgroupBlockSide(uint32_t subgroupSize);

Result<nlohmann::json> runEdgesSweep(gpu::Context& ctx, const EdgesSweepSpec& spec,
                                     const SweepOptions& options);

}  // namespace tally::sweeps
