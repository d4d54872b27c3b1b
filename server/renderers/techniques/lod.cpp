#include "renderers/techniques/lod.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>

#include <meshoptimizer.h>

#include "renderers/gpu_scene.hpp"
#include "shared.h"

namespace tally::renderers {

SimplifiedLevels simplifyLevels(std::span<const uint32_t> indices, const float* positions, size_t vertexCount,
                                size_t stride) {
  SimplifiedLevels out;
  if (indices.size() < 2 * kLodMinIndices || vertexCount == 0) return out;
  const float scale = meshopt_simplifyScale(positions, vertexCount, stride);
  std::vector<uint32_t> level(indices.size());
  size_t previous = indices.size();
  float previousError = 0.0f;
  while (out.indices.size() + 1 < kLodMaxLevels) {
    const size_t target = previous / 2 / 3 * 3;
    if (target < kLodMinIndices) break;
    float relative = 0.0f;
    // From the original each time, so that the error is against level 0;
    // target_error 1 (the whole extent): the index target is the limit.
    const size_t count = meshopt_simplify(level.data(), indices.data(), indices.size(), positions, vertexCount,
                                          stride, target, 1.0f, meshopt_SimplifyLockBorder, &relative);
    if (count == 0 || count >= previous || count < kLodMinIndices) break;
    previousError = std::max(previousError, relative * scale);
    out.indices.emplace_back(level.begin(), level.begin() + std::ptrdiff_t(count));
    out.errors.push_back(previousError);
    previous = count;
  }
  return out;
}

float pixelsPerUnitAtUnitDistance(float viewportHeight, float fovYRad) {
  return viewportHeight / (2.0f * std::tan(fovYRad / 2.0f));
}

float projectedErrorPx(float worldError, float distance, float viewportHeight, float fovYRad) {
  return worldError / std::max(distance, 1e-4f) * pixelsPerUnitAtUnitDistance(viewportHeight, fovYRad);
}

float sphereDistance(const LodChain& chain, glm::vec3 eye) {
  return std::max(glm::length(eye - chain.center) - chain.radius * chain.modelScale, 0.0f);
}

uint32_t selectLevel(const LodChain& chain, glm::vec3 eye, float viewportHeight, float fovYRad, float thresholdPx) {
  const float distance = sphereDistance(chain, eye);
  uint32_t best = 0;
  for (uint32_t l = 1; l < chain.levels.size(); ++l) {
    const float px = projectedErrorPx(chain.levels[l].error * chain.modelScale, distance, viewportHeight, fovYRad);
    if (px <= thresholdPx) best = l;
  }
  return best;
}

SceneLod::~SceneLod() {
  if (ctx_ != nullptr) gpu::destroyBuffer(*ctx_, indices_);
}

Result<std::unique_ptr<SceneLod>> SceneLod::build(const gpu::Context& ctx, const GpuScene& scene) {
  const auto start = std::chrono::steady_clock::now();
  const auto& draws = scene.draws();
  uint64_t originalCount = 0;
  for (const auto& d : draws) originalCount = std::max<uint64_t>(originalCount, uint64_t(d.firstIndex) + d.indexCount);
  const std::vector<uint8_t> indexBytes = gpu::readBuffer(ctx, scene.indices(), 0, originalCount * 4);
  const std::vector<uint8_t> vertexBytes = gpu::readBuffer(ctx, scene.vertices());
  const std::vector<uint8_t> drawBytes = gpu::readBuffer(ctx, scene.drawBuffer());
  std::vector<uint32_t> all(originalCount);
  std::memcpy(all.data(), indexBytes.data(), originalCount * 4);
  const size_t vertexTotal = vertexBytes.size() / sizeof(shaders::Vertex);
  const auto* vertices = reinterpret_cast<const shaders::Vertex*>(vertexBytes.data());

  std::unique_ptr<SceneLod> lod(new SceneLod());
  lod->ctx_ = &ctx;
  for (uint32_t i = 0; i < draws.size(); ++i) {
    const GpuDraw& d = draws[i];
    std::span<const uint32_t> local(all.data() + d.firstIndex, d.indexCount);
    uint32_t vertexCount = 0;
    for (uint32_t v : local) vertexCount = std::max(vertexCount, v + 1);
    if (size_t(d.vertexOffset) + vertexCount > vertexTotal) {
      return makeError("lod: draw " + std::to_string(i) + " indexes past the vertex buffer");
    }
    const shaders::Vertex* base = vertices + d.vertexOffset;
    LodChain chain;
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (uint32_t v : local) {
      glm::vec3 p(base[v].position[0], base[v].position[1], base[v].position[2]);
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    chain.center = (lo + hi) * 0.5f;
    for (uint32_t v : local) {
      glm::vec3 p(base[v].position[0], base[v].position[1], base[v].position[2]);
      chain.radius = std::max(chain.radius, glm::length(p - chain.center));
    }
    glm::mat4 model;
    std::memcpy(&model, drawBytes.data() + size_t(i) * sizeof(shaders::DrawData), sizeof model);
    chain.modelScale = glm::length(glm::vec3(model[0]));
    chain.center = glm::vec3(model * glm::vec4(chain.center, 1.0f));
    chain.levels.push_back({d.firstIndex, d.indexCount, 0.0f});
    SimplifiedLevels levels = simplifyLevels(local, base[0].position, vertexCount, sizeof(shaders::Vertex));
    for (size_t l = 0; l < levels.indices.size(); ++l) {
      chain.levels.push_back({uint32_t(all.size()), uint32_t(levels.indices[l].size()), levels.errors[l]});
      all.insert(all.end(), levels.indices[l].begin(), levels.indices[l].end());
    }
    lod->chains_.push_back(std::move(chain));
  }
  lod->indexCount_ = all.size();
  lod->indices_ = gpu::createBuffer(
      ctx, std::max<VkDeviceSize>(all.size() * 4, 16),
      VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
      gpu::MemoryUse::DeviceLocal);
  gpu::uploadBuffer(ctx, lod->indices_, {reinterpret_cast<const uint8_t*>(all.data()), all.size() * 4});
  lod->buildMs_ = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return lod;
}

LodSelection::~LodSelection() {
  if (ctx_ != nullptr) gpu::destroyBuffer(*ctx_, draws_);
}

Result<bool> LodSelection::setup(const gpu::Context& ctx, const GpuScene& scene, float thresholdPx) {
  auto lod = scene.lod();
  if (!lod) return makeError(lod.error());
  ctx_ = &ctx;
  lod_ = *lod;
  threshold_ = thresholdPx;
  chosen_.assign(lod_->chains().size(), 0);
  drawData_ = gpu::readBuffer(ctx, scene.drawBuffer(), 0, chosen_.size() * sizeof(shaders::DrawData));
  draws_ = gpu::createBuffer(ctx, std::max<VkDeviceSize>(drawData_.size(), 16), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                             gpu::MemoryUse::Upload);
  uint64_t original = 0;
  for (const auto& d : scene.draws()) original = std::max<uint64_t>(original, uint64_t(d.firstIndex) + d.indexCount);
  originalIndexBytes_ = original * sizeof(uint32_t);
  return true;
}

const LodLevel& LodSelection::chosen(uint32_t draw) const { return lod_->chains()[draw].levels[chosen_[draw]]; }

const gpu::Buffer& LodSelection::indexBuffer() const { return lod_->indices(); }

uint64_t LodSelection::indexAllocationBytes() const {
  VkMemoryRequirements r;
  vkGetBufferMemoryRequirements(ctx_->device, lod_->indices().buffer, &r);
  return r.size;
}

void LodSelection::select(const scenes::Camera& camera, VkExtent2D extent) {
  const float fov = glm::radians(camera.fovDeg), height = float(extent.height);
  maxProjected_ = 0;
  for (uint32_t i = 0; i < chosen_.size(); ++i) {
    const LodChain& chain = lod_->chains()[i];
    chosen_[i] = selectLevel(chain, camera.eye, height, fov, threshold_);
    const LodLevel& l = chain.levels[chosen_[i]];
    maxProjected_ = std::max(
        maxProjected_, projectedErrorPx(l.error * chain.modelScale, sphereDistance(chain, camera.eye), height, fov));
    auto* d = reinterpret_cast<shaders::DrawData*>(drawData_.data() + size_t(i) * sizeof(shaders::DrawData));
    d->firstIndex = l.firstIndex;
    d->indexCount = l.indexCount;
  }
  gpu::uploadBuffer(*ctx_, draws_, drawData_);
}

nlohmann::json LodSelection::extras() const {
  uint64_t full = 0, drawn = 0;
  std::vector<uint64_t> histogram;
  for (uint32_t i = 0; i < chosen_.size(); ++i) {
    const LodChain& chain = lod_->chains()[i];
    full += chain.levels[0].indexCount / 3;
    drawn += chain.levels[chosen_[i]].indexCount / 3;
    if (histogram.size() <= chosen_[i]) histogram.resize(chosen_[i] + 1, 0);
    ++histogram[chosen_[i]];
  }
  return {{"threshold_px", threshold_},
          {"triangles_full", full},
          {"triangles_drawn", drawn},
          {"levels", histogram},
          {"max_projected_error_px", maxProjected_},
          {"index_buffer_bytes_added", lod_->indexCount() * sizeof(uint32_t) - originalIndexBytes_}};
}

}  // namespace tally::renderers
