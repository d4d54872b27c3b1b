// The two passes both visibility-buffer renderers share: the visibility
// pass (ids and whatever else the variant stores, D32_S8 depth, stencil 1 on
// geometry) and the full-screen shading pass (stencil == 1) that reads the
// visibility targets, the mesh and all five maps of the pixel's material.
//
// Material maps, chosen per device: with descriptor indexing (NVIDIA), the
// shaders' materialMaps[kMaxMaterialMaps] with nonuniformEXT, element per
// texture (counts attributed per element to its texture's kind); without it
// (lavapipe), one sampler2DArray per map kind (shaders compiled with
// TALLY_MAP_ARRAYS), the layer per pixel from Material::maps, maps of one
// kind resized to the largest of that kind. Both select per pixel, unless
// RendererOptions::materialSelection asks for the founding study's uniform
// index or the first-lane model (shading.frag's SAMPLE_MAP).
#pragma once

#include <string>
#include <vector>

#include "renderers/techniques/msaa.hpp"
#include "renderers/renderer_base.hpp"

namespace tally::renderers {

// The visibility id packs the draw and the triangle within it into 32 bits
// (shared.h): at most shaders::kMaxDraws (512) draws of at most
// shaders::kTriangleIdMask (8,388,607) triangles each; the all-ones id is the
// clear value. Beyond that ids would alias and the shading pass would fetch
// the wrong triangle, so a scene that does not fit is refused, never drawn.
// Empty when `draws` fits, else the limit and the scene's count.
std::string visibilityIdOverflow(const std::vector<GpuDraw>& draws);

// Why `selection` cannot run on this device ("" when it can): "uniform" needs
// descriptor indexing, "first-lane" subgroup ballot in fragment shaders.
// Setup fails with this reason, prefixed with the renderer's name.
std::string materialSelectionUnsupported(const gpu::Context& ctx, MaterialSelection selection);

class VisbufferBase : public RendererBase {
 public:
  nlohmann::json notes() const override;
  // Bloom's, plus {"msaa": msaaExtras(...)} with msaa > 1 (renderers/techniques/msaa.hpp).
  nlohmann::json frameExtras() override;

 protected:
  bool indexedMaps() const;  // the descriptor-indexing path (needs setup's context and scene)
  // Fails with visibilityIdOverflow's reason when the scene does not fit the id.
  Result<bool> checkIdCapacity() const;
  void addMapResources();    // the material map resources of the chosen path
  // msaa > 1 (RendererOptions::msaa): the visibility targets have N samples,
  // the visibility pass renders "depth.msaa" (N samples), the shading pass
  // fetches every sample's id, shades each distinct triangle once weighted by
  // its samples and marks the 1-sample "depth" (renderers/techniques/msaa.hpp). Fails
  // naming the limit when the device lacks N for these targets.
  Result<bool> checkMsaa(const std::vector<MsaaTarget>& targets) const;
  uint32_t targetSamples() const { return options_.msaa; }
  // The visibility pass's writes: per covered sample (msaa.hpp, scaleSampleWrites).
  FrameResult finishFrame(FrameResult frame) override;
  // shading=compute: "hdr" is a storage image (compute_shading.cpp).
  VkImageUsageFlags hdrExtraUsage() const override { return computeShadingUsage(); }
  struct Target {
    const gpu::Image* image = nullptr;
    std::string name;  // ResourceInfo name
  };
  std::vector<std::string> ownPassNames() const override { return {"visibility", "shading"}; }
  // Visibility targets are cleared to shaders::kVisibilityClear. `defines`
  // go to the fragment shader (the variant's encoding).
  Result<bool> addVisibilityPass(const std::string& vertex, const std::string& fragment,
                                 const std::vector<Target>& targets, const std::vector<std::string>& defines = {});
  // `inputs` at set 3, bindings 0, 1, ... in order; `defines` as above, beside
  // those of the map path and material selection.
  Result<bool> addShadingPass(const std::string& fragment, const std::vector<Target>& inputs,
                              const std::vector<std::string>& defines = {});
};

}  // namespace tally::renderers
