// Camera heatmaps: poses on a grid over a scene's walkable floor, or on a
// sphere around it, one renderer (or the ratio of two) measured at each
// (docs/measurement.md, "Camera heatmaps"). This file holds the spec's
// "heatmap" object, the placement of the poses with the BVH, the layout that
// lets a reader rebuild the map from stored samples, and the top-down plan
// image the dashboard draws the floor map over. Pure CPU, no Vulkan.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "scenes/bvh.hpp"
#include "scenes/scene.hpp"

namespace tally::scenes {

// Limits on one "heatmap" object. Poses per scene are also bounded by the
// capture's sample matrix (capture::kMaxMatrix, and the service's tighter one).
inline constexpr uint32_t kMaxHeatmapCells = 256;     // per axis of a floor grid
inline constexpr uint32_t kMaxHeatmapYaws = 16;       // horizontal directions per floor cell
inline constexpr uint32_t kMaxHeatmapRings = 90;      // latitudes of a sphere
inline constexpr uint32_t kMaxHeatmapSegments = 180;  // longitudes of a sphere
inline constexpr uint32_t kMaxHeatmapPoses = 10000;   // cells x yaws, or rings x segments
// The top-down image's longer side, in pixels (one ray per pixel).
inline constexpr uint32_t kTopDownMaxSide = 1024;

struct HeatmapSpec {
  enum class Layout { Floor, Sphere };
  Layout layout = Layout::Floor;
  // Floor: a columns x rows grid over the region (x, z) in the ground
  // plane; default region: the scene's bounds.
  uint32_t columns = 16, rows = 8;
  std::optional<std::array<float, 4>> region;  // x0, z0, x1, z1 (x0 < x1, z0 < z1)
  float eyeHeight = 1.7f;    // metres above the floor
  uint32_t yaws = 4;         // directions, evenly from yaw 0 (+X), turning towards +Z
  float pitchDeg = 0.0f;     // of every floor pose
  float headroom = 2.0f;     // free height above a floor (> eyeHeight)
  float clearance = 0.25f;   // nothing this close to the eye, in any of 26 directions
  float maxSlopeDeg = 30.0f; // a floor's normal within this of +Y
  float maxRise = 1.0f;      // a floor within this of the ground level (the median floor)
  // Sphere: rings x segments poses (latitude x longitude, cell centres) at
  // `distance` bounding-sphere radii from the bounds' centre, looking at it.
  uint32_t rings = 6, segments = 12;
  float distance = 2.0f;
  float fovDeg = 60.0f;  // vertical, every pose

  // Poses asked for at most (floor: cells x yaws; empty cells drop out).
  size_t maxPoses() const { return layout == Layout::Floor ? size_t(columns) * rows * yaws : size_t(rings) * segments; }
};

// Parses a spec's "heatmap" object. Errors name the field from "heatmap"
// down: "heatmap.cells[1]: must be an integer between 1 and 256, got 0".
//   {"layout": "floor", "cells": [16, 8], "eye_height": 1.7, "yaws": 4, "pitch_deg": 0,
//    "fov_deg": 60, "headroom": 2, "clearance": 0.25, "max_slope_deg": 30, "max_rise": 1,
//    "region": [[x0, z0], [x1, z1]]}
//   {"layout": "sphere", "rings": 6, "segments": 12, "distance": 2, "fov_deg": 60}
Result<HeatmapSpec> parseHeatmapSpec(const nlohmann::json& j);

// One pose: a camera and the cell it belongs to. Floor: column along x, row
// along z, yaw index. Sphere: column = longitude segment, row = latitude ring
// (row 0 the northernmost, +Y), yaw 0.
struct HeatmapPose {
  Camera camera;
  uint32_t column = 0, row = 0, yaw = 0;
};

struct HeatmapPlacement {
  std::vector<HeatmapPose> poses;  // row-major over cells, yaws innermost
  // The layout a reader rebuilds the map from (docs/result-schema.md,
  // "Heatmaps"): kind, grid, origin, cell size, axes, floor height per cell
  // (null where empty) with the reason for each empty cell, the top-down
  // image's world-to-pixel mapping.
  nlohmann::json layout;
};

// Why a floor cell is empty (the layout's "empty" grid).
inline constexpr const char* kNoSurface = "no_surface";    // nothing below faces up within max_slope_deg
inline constexpr const char* kNoHeadroom = "no_headroom";  // every such surface has less than `headroom` above it
inline constexpr const char* kEyeBlocked = "eye_blocked";  // ... or an eye in or next to geometry
inline constexpr const char* kOffLevel = "off_level";      // the lowest valid floor is more than max_rise off the ground

// Places the poses (docs/measurement.md, "Camera heatmaps", states the floor
// rule). Deterministic for a scene and spec.
HeatmapPlacement placeHeatmap(const Scene& scene, const Bvh& bvh, const HeatmapSpec& spec);
HeatmapPlacement placeHeatmap(const Scene& scene, const HeatmapSpec& spec);  // builds the BVH

// The camera JSON's "heatmap" object of a pose: {"column", "row", "yaw", "yaw_deg"}.
nlohmann::json poseJson(const HeatmapPose& pose, const HeatmapSpec& spec);

struct TopDownImage {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;  // rows top (z0) to bottom (z1), columns x0 to x1
};

// A top-down orthographic plan of a floor layout: one ray per pixel straight
// down from the layout's cut height (ground + eye height), over the layout's
// image rectangle (layout["image"]: x0, z0, x1, z1, width, height). The first
// surface below is shaded by its depth below the cut and its slope; geometry
// the cut passes through is dark, as a plan's section: a surface crossing the
// cut height inside the pixel (walls, however thin: two horizontal rays
// across the pixel) and solids the ray starts inside (it sees a back face);
// where nothing is below the pixel is transparent.
// Error for a layout that is not a floor layout or lacks those fields.
Result<TopDownImage> renderTopDown(const Scene& scene, const Bvh& bvh, const nlohmann::json& layout);

}  // namespace tally::scenes
