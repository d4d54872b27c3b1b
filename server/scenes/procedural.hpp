// Deterministic in-tree scenes. Each exists to exercise one effect with the
// fewest triangles that show it (DESIGN.md, "Data"):
// - atrium: the default; a Sponza-like court for realistic overshading, sky
//   fraction and material variety, in a few thousand triangles.
// - planes: N stacked full-screen (or `coverage`) quads; overdraw and early-z
//   with analytically known fragment and texture-read counts.
// - sky: one quad covering the bottom `coverage` of the screen; the sky mask.
#pragma once

#include <cstdint>

#include "scenes/scene.hpp"

namespace tally::scenes {

enum class DrawOrder { BackToFront, FrontToBack };
const char* toString(DrawOrder order);  // "back-to-front", "front-to-back"

constexpr int kMaxPlaneLayers = 1024;

struct PlanesParams {
  int layers = 8;                            // [1, kMaxPlaneLayers]
  DrawOrder order = DrawOrder::BackToFront;  // order of the quads in the draw (mesh) order
  double coverage = 1.0;                     // (0, 1]: fraction of the screen area each quad covers
};

struct SkyParams {
  double coverage = 0.5;  // [0, 1]: fraction of the screen the geometry covers (bottom rows)
};

// The analytic scenes (planes, sky) are exact for any viewport aspect ratio up
// to this (width / height): their quads span the full width of such a view.
constexpr float kMaxAnalyticAspect = 4.0f;

Scene makeAtrium();
Scene makePlanes(const PlanesParams& params);
Scene makeSky(const SkyParams& params);

}  // namespace tally::scenes
