// raytrace: procedural spheres on a ground plane, primary, shadow and
// reflection rays per pixel (workloads.hpp has the model).
#include <algorithm>
#include <cmath>
#include <cstring>

#include "renderers/renderers.hpp"
#include "renderers/techniques/tile_memory.hpp"
#include "renderers/workloads/workload_base.hpp"

namespace tally::renderers {

using nlohmann::json;

namespace {

struct RayParams {     // std140; raytrace.comp.glsl's RayBlock
  glm::vec4 light;     // xyz: position; w: ground plane y
  glm::vec4 params;    // x: epsilon
  glm::uvec4 counts;   // x: spheres, y: bounces
};

class Raytrace final : public WorkloadBase {
 public:
  std::string_view name() const override { return "raytrace"; }

  nlohmann::json frameExtras() override {
    json extras = RendererBase::frameExtras();
    extras.erase("tangent_frame");
    const WorkloadOptions& o = options_.workload;
    // Per pixel the pass leaves shadow rays x 8 + reflection rays in alpha.
    uint64_t primary = 0, shadow = 0, reflection = 0;
    for (float a : hdrAlpha()) {
      uint32_t code = uint32_t(std::lround(a));
      ++primary;
      shadow += code / 8;
      reflection += code % 8;
    }
    json rt = {{"spheres", o.spheres},
               {"bounces", o.bounces},
               {"rays", {{"primary", primary}, {"shadow", shadow}, {"reflection", reflection},
                         {"total", primary + shadow + reflection}}},
               {"sphere_tests_predicted", (primary + shadow + reflection) * o.spheres}};
    if (options_.instrumented && sphereReads_ >= 0) rt["sphere_reads"] = sphereReads_;
    extras["raytrace"] = rt;
    return extras;
  }

 protected:
  std::vector<std::string> ownPassNames() const override { return {"raytrace"}; }

  FrameResult finishFrame(FrameResult frame) override {
    sphereReads_ = -1;
    for (const auto& p : frame.passes) {
      if (p.name != "raytrace") continue;
      sphereReads_ = 0;
      for (const auto& a : p.accesses) {
        if (a.resource == "spheres" && !a.write) sphereReads_ += int64_t(a.count);
      }
    }
    return frame;
  }

  Result<bool> setupPasses() override {
    const WorkloadOptions& o = options_.workload;
    if (o.spheres < 1 || o.spheres > 4096) return makeError("spheres: must be 1 to 4096");
    if (o.bounces > 3) return makeError("bounces: must be 0 to 3, got " + std::to_string(o.bounces));
    const scenes::Bounds& bounds = scene_->bounds();
    const std::vector<glm::vec4> spheres = raytraceSpheres(bounds, o.spheres);
    buffer(data_, "spheres", spheres.data(), spheres.size() * sizeof(glm::vec4), sizeof(glm::vec4), true);
    RayParams params = {glm::vec4(raytraceLight(bounds), bounds.min.y),
                        glm::vec4(raytraceEpsilon(bounds), 0, 0, 0), glm::uvec4(o.spheres, o.bounces, 0, 0)};
    buffer(params_, "raytrace_params", &params, sizeof params, sizeof params, false);
    VkDescriptorSetLayout layout = setLayout({VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER,
                                              VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER});
    VkDescriptorSet set = allocateSet(layout);
    writeBuffer(set, 1, VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, data_);
    writeBuffer(set, 2, VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, params_);
    inputs_ = {{1, "spheres"}, {2, "raytrace_params"}};
    return addComputePass("raytrace", "raytrace.comp.glsl", {}, layout, set);
  }

 private:
  int64_t sphereReads_ = -1;
};

}  // namespace

std::unique_ptr<Renderer> makeRaytrace() { return std::make_unique<Raytrace>(); }

}  // namespace tally::renderers
