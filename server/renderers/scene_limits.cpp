#include "renderers/scene_limits.hpp"

#include "shared.h"

namespace tally::renderers {

std::string featureRefusal(std::string_view renderer, const scenes::Scene::Features& f,
                           const RendererOptions& options) {
  const std::string who = std::string(renderer) + ": ";
  if (f.alphaBlend && options.msaa > 1) {
    return who + "alphaMode BLEND with msaa " + std::to_string(options.msaa) +
           " is not supported (the transparent pass tests the 1-sample depth, which holds no depth with msaa)";
  }
  const bool forward = renderer == "forward" || renderer == "forward-zprepass";
  if (forward && f.alphaMask && options.forwardOutput == ForwardOutput::Overdraw) {
    return who + "alphaMode MASK with output=overdraw is not supported (overdraw counts with the depth test off)";
  }
  if (renderer == "deferred" && f.emissive) {
    // The emission travels in a fourth G-buffer target read by the fragment lighting pass only.
    if (options.gbufferSubpass) return who + "emissive materials with gbuffer=subpass are not supported";
    if (options.computeShading) return who + "emissive materials with shading=compute are not supported";
    if (options.msaa > 1) return who + "emissive materials with msaa " + std::to_string(options.msaa) + " are not supported";
  }
  return "";
}

std::string sceneRefusal(std::string_view renderer, const scenes::Scene& scene, const RendererOptions& options) {
  if (renderer == "visbuffer" || renderer == "visbuffer-lean") {
    const std::string who = std::string(renderer) + ": ";
    if (scene.meshes.size() > shaders::kMaxDraws) {
      return who + "the scene has " + std::to_string(scene.meshes.size()) +
             " draws; the visibility id holds at most " + std::to_string(shaders::kMaxDraws) + " (" +
             std::to_string(shaders::kDrawIdBits) + " bits of draw id)";
    }
    for (size_t i = 0; i < scene.meshes.size(); ++i) {
      if (scene.meshes[i].triangleCount() > shaders::kTriangleIdMask) {
        return who + "draw " + std::to_string(i) + " has " + std::to_string(scene.meshes[i].triangleCount()) +
               " triangles; the visibility id holds at most " + std::to_string(shaders::kTriangleIdMask) +
               " per draw";
      }
    }
  }
  return featureRefusal(renderer, scene.features(), options);
}

}  // namespace tally::renderers
