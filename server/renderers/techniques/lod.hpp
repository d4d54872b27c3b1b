// Levels of detail (docs/techniques.md, "Levels of detail"): per draw of a
// GpuScene, a chain of successively simplified index ranges built with
// meshoptimizer's simplifier, each with its geometric error; per frame, per
// draw, the coarsest level whose error projected to the screen stays under a
// pixel threshold (RendererOptions::lodThresholdPx).
//
// The chains are built only when a renderer asks for LOD (GpuScene::lod(),
// then cached with the scene). Level 0 is the draw's own range of the scene's
// index buffer; the coarser levels are appended after all original indices in
// a second index buffer that holds both (the "indices" resource of a renderer
// with LOD on: that growth is real memory).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/result.hpp"
#include "gpu/context.hpp"
#include "gpu/resources.hpp"
#include "renderers/renderer.hpp"
#include "scenes/scene.hpp"

namespace tally::renderers {

class GpuScene;

constexpr uint32_t kLodMaxLevels = 8;     // level 0 included
constexpr uint32_t kLodMinIndices = 3 * 16;  // no level below 16 triangles is built

struct LodLevel {
  uint32_t firstIndex = 0;  // into the LOD index buffer (level 0: the draw's own firstIndex)
  uint32_t indexCount = 0;
  // Object-space error (scene units): meshopt_simplify's result error
  // (relative to the mesh extent) x meshopt_simplifyScale; 0 for level 0;
  // never below the finer level's (the chain is made monotone).
  float error = 0.0f;
};

struct LodChain {
  std::vector<LodLevel> levels;  // finest first; index counts strictly decrease
  glm::vec3 center{0.0f};        // bounding sphere of the draw's vertices (object space)
  float radius = 0.0f;
  float modelScale = 1.0f;       // DrawData::model's uniform scale (world error = error x scale)
};

// One mesh's simplified levels 1.. (level 0 is `indices` itself): each
// targets half the previous level's index count, simplified from the
// original with borders locked (meshes that share an edge keep it, so no
// cracks open between them); stops when a level no longer reduces, falls
// below kLodMinIndices or kLodMaxLevels is reached. errors[i] is level i+1's
// object-space error (monotone). `positions` is xyz floats with `stride` bytes.
struct SimplifiedLevels {
  std::vector<std::vector<uint32_t>> indices;
  std::vector<float> errors;
};
SimplifiedLevels simplifyLevels(std::span<const uint32_t> indices, const float* positions, size_t vertexCount,
                                size_t stride);

// Pixels per radian at the image centre: height / (2 tan(fovY / 2)).
float pixelsPerUnitAtUnitDistance(float viewportHeight, float fovYRad);
// worldError / distance x height / (2 tan(fovY / 2)); distance is to the
// bounding sphere (from the eye to its surface), at least 1e-4: inside the
// sphere every error is projected as if from very near (level 0).
float projectedErrorPx(float worldError, float distance, float viewportHeight, float fovYRad);
float sphereDistance(const LodChain& chain, glm::vec3 eye);
// The coarsest level whose projected error is <= thresholdPx (0 when none is).
uint32_t selectLevel(const LodChain& chain, glm::vec3 eye, float viewportHeight, float fovYRad, float thresholdPx);

// The chains of every draw of a scene and the index buffer holding them.
class SceneLod {
 public:
  ~SceneLod();
  // Reads the scene's vertices, indices and draws back from the device.
  static Result<std::unique_ptr<SceneLod>> build(const gpu::Context& ctx, const GpuScene& scene);
  const std::vector<LodChain>& chains() const { return chains_; }
  const gpu::Buffer& indices() const { return indices_; }  // original indices, then levels 1..
  uint64_t indexCount() const { return indexCount_; }
  double buildMs() const { return buildMs_; }

 private:
  SceneLod() = default;
  const gpu::Context* ctx_ = nullptr;
  std::vector<LodChain> chains_;
  gpu::Buffer indices_;
  uint64_t indexCount_ = 0;
  double buildMs_ = 0;
};

// A renderer's LOD state with LOD on: the chosen level per draw and a
// host-visible copy of the draws buffer whose firstIndex/indexCount are the
// chosen level's, rewritten each frame (the visibility buffers' shading
// passes fetch the triangles the visibility pass drew through it).
class LodSelection {
 public:
  ~LodSelection();
  Result<bool> setup(const gpu::Context& ctx, const GpuScene& scene, float thresholdPx);
  // Chooses every draw's level for `camera` and writes the draws buffer.
  void select(const scenes::Camera& camera, VkExtent2D extent);
  uint32_t level(uint32_t draw) const { return chosen_[draw]; }
  const LodLevel& chosen(uint32_t draw) const;
  const gpu::Buffer& drawBuffer() const { return draws_; }
  const gpu::Buffer& indexBuffer() const;
  uint64_t indexAllocationBytes() const;  // VkMemoryRequirements::size of indexBuffer()
  // {"threshold_px", "triangles_full", "triangles_drawn", "levels": [draws
  // per level], "max_projected_error_px", "index_buffer_bytes_added"}.
  nlohmann::json extras() const;

 private:
  const gpu::Context* ctx_ = nullptr;
  const SceneLod* lod_ = nullptr;
  float threshold_ = 0;
  std::vector<uint32_t> chosen_;
  std::vector<uint8_t> drawData_;  // shaders::DrawData[] as the scene uploaded it
  gpu::Buffer draws_;
  float maxProjected_ = 0;
  uint64_t originalIndexBytes_ = 0;
};

}  // namespace tally::renderers
