// GET /api/heatmap and GET /api/heatmap/{capture}/topdown.png: a heatmap
// capture's map (one renderer's value per cell, or two renderers' and their
// ratio with the significance of the difference) rebuilt from the stored
// samples and the layout in the runs' notes, and the top-down plan of a floor
// layout rendered from the scene's triangles. docs/api.md describes the
// answer and docs/measurement.md ("Camera heatmaps") the rule behind it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "store/store.hpp"

namespace tally::reports {

inline constexpr int kHeatmapMaxRuns = 2000;  // runs of one capture considered

struct HeatmapQuery {
  int64_t capture = 0;
  std::string renderer;                // variant label of A
  std::optional<std::string> versus;   // variant label of B
  std::string metric = "frame_ms";     // frame_ms | bytes
  std::string yaw = "mean";            // mean | worst | a yaw index ("0", "1", ...)
  std::optional<std::string> scene, counting;
  std::optional<int> width, height;
};

// Why there is no map or plan: what was asked is not valid (naming the
// field), what it names is not there, or the store failed.
struct HeatmapFailure {
  enum class Kind { kInvalid, kMissing, kStore };
  Kind kind = Kind::kInvalid;
  std::string field, message;
};

struct HeatmapAnswer {
  std::optional<HeatmapFailure> failure;
  nlohmann::json body;       // the map (heatmapMap)
  std::vector<uint8_t> png;  // the plan (heatmapTopDown)
};

// The capture must exist (the route checks). Invalid queries name the field:
// renderer (no run of it, or several to choose between), versus, yaw,
// capture (not a heatmap capture).
HeatmapAnswer heatmapMap(store::Store& store, const HeatmapQuery& query);

// The plan of the floor layout of the capture's heatmap runs on `scene`
// (optional when it has one heatmap scene), as PNG; cached per capture and
// scene. A glTF scene is read again only from inside `sceneFolders`. Missing
// for a sphere layout, a scene file that is gone or outside the folders.
HeatmapAnswer heatmapTopDown(store::Store& store, int64_t capture, const std::optional<std::string>& scene,
                             const std::vector<std::filesystem::path>& sceneFolders);

}  // namespace tally::reports
